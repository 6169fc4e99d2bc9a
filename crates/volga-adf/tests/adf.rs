//! ADF accuracy, signs, CSG, edits, determinism and hard cases, against exact distances.

use glam::DVec3;
use volga_adf::{Adf, AdfError, AdfOptions, AdfSource, CsgOp, DistanceSource, MeshSource, ShapeSource};
use volga_core::Aabb;
use volga_mesh::{unclean, ExtractMethod, Extraction, TriMesh};
use volga_shapes::{AxisBox, SignedDistance, Sphere, Torus};

mod common;
use common::Rng;

fn options(tolerance: f64, max_depth: u8) -> AdfOptions {
    AdfOptions {
        tolerance,
        max_depth,
        max_cells: 50_000_000,
        margin: None,
        band: 0.0,
    }
}

/// Max error of the reconstruction against the exact distance at random points within
/// `band` of the surface, in leaves the tolerance applies to (not pruned as far from the
/// surface, not at the maximum depth), and how many points were tested; also the largest
/// error in maximum-depth leaves (creases of the distance, which no depth resolves).
fn band_error(adf: &Adf, exact: &dyn Fn(DVec3) -> f64, band: f64, seed: u64) -> (f64, usize, f64) {
    let mut rng = Rng(seed);
    let root = adf.root_box();
    let (mut worst, mut n, mut at_max_depth) = (0.0f64, 0, 0.0f64);
    let mut tries = 0;
    while n < 4000 && tries < 1_000_000 {
        tries += 1;
        let p = rng.in_box(&root);
        let d = exact(p);
        let leaf = adf.leaf_at(p);
        if d.abs() > band || leaf.pruned {
            continue;
        }
        let err = (adf.distance(p) - d).abs();
        if leaf.depth == adf.options().max_depth {
            at_max_depth = at_max_depth.max(err);
            continue;
        }
        worst = worst.max(err);
        n += 1;
    }
    (worst, n, at_max_depth)
}

#[test]
fn analytic_shapes_are_within_tolerance_near_their_surfaces() {
    let sphere = Sphere::new(DVec3::new(0.1, -0.2, 0.3), 0.8).unwrap();
    let torus = Torus::new(DVec3::ZERO, DVec3::new(0.0, 0.3, 1.0), 0.7, 0.25).unwrap();
    let boxed = AxisBox::new(DVec3::new(-0.6, -0.4, -0.5), DVec3::new(0.5, 0.7, 0.4)).unwrap();
    check_shape("sphere", sphere);
    check_shape("torus", torus);
    check_shape("box", boxed);
}

fn check_shape<S: SignedDistance + Sync + Copy>(name: &str, shape: S) {
    for tolerance in [1e-2, 1e-3] {
        let adf = Adf::build(&ShapeSource(shape), options(tolerance, 10)).unwrap();
        let exact = |p: DVec3| shape.signed_distance(p);
        let (worst, n, at_max_depth) = band_error(&adf, &exact, 0.1, 7);
        assert!(n >= 1000, "{name}: {n} points");
        assert!(
            worst <= tolerance,
            "{name} at {tolerance}: max error {worst:e} over {n} points, {:?}",
            adf.stats()
        );
        // Smooth surfaces never reach the maximum depth; the box's distance has creases
        // (its interior medial axis), whose cells stop there with errors of a cell's size.
        if name == "box" {
            assert!(
                at_max_depth <= adf.cell_size(10),
                "{name}: {at_max_depth:e} at the maximum depth"
            );
        } else {
            assert_eq!(adf.stats().max_depth_leaves, 0, "{name}: {:?}", adf.stats());
        }
    }
}

#[test]
fn sphere_reconstruction_matches_at_test_points_and_gradients_are_unit() {
    let sphere = Sphere::new(DVec3::ZERO, 1.0).unwrap();
    let adf = Adf::build(&ShapeSource(sphere), options(1e-4, 12)).unwrap();
    let mut rng = Rng(3);
    for _ in 0..500 {
        let dir = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5).normalize();
        let p = dir * (0.9 + 0.2 * rng.next());
        let g = adf.gradient(p);
        assert!((g.length() - 1.0).abs() < 0.05, "gradient {g} at {p}");
        assert!(g.normalize().dot(dir) > 0.99);
        // Closest point lands on the sphere within the tolerance (plus the gradient error).
        let c = adf.closest_point(p);
        assert!((c.length() - 1.0).abs() < 2e-3, "closest point {c} of {p}");
    }
}

/// `inside` against the exact sign, both ways: at random points near a sphere, inside
/// ⇒ the exact distance is ≤ 0 and exact distance ≤ 0 ⇒ inside, for every point farther
/// from the surface than the tolerance (the reconstruction is within it there, so the
/// signs must agree); on an axis-aligned box's face, where the reconstruction of the
/// linear distance is exact (dyadic corners and points), the same at ties (exact
/// distance 0: inside) and one 2⁻²⁰ step off the face on either side.
#[test]
fn inside_agrees_with_the_exact_sign_both_ways() {
    let tolerance = 1e-4;
    let sphere = Sphere::new(DVec3::ZERO, 1.0).unwrap();
    let adf = Adf::build(&ShapeSource(sphere), options(tolerance, 12)).unwrap();
    let mut rng = Rng(5);
    let (mut inside, mut outside) = (0, 0);
    for _ in 0..20_000 {
        let dir = rng.unit();
        let p = dir * (1.0 + 4.0 * tolerance * (2.0 * rng.next() - 1.0));
        let exact = sphere.signed_distance(p);
        if exact.abs() <= tolerance {
            continue;
        }
        let reference = exact <= 0.0;
        assert_eq!(
            adf.inside(p),
            reference,
            "{p}: exact {exact:e}, reconstructed {:e}",
            adf.distance(p)
        );
        inside += reference as usize;
        outside += !reference as usize;
    }
    assert!(inside > 5000 && outside > 5000, "{inside} inside, {outside} outside");

    // The face x = 0.5 of a box: the distance is x − 0.5 near the face's centre.
    let cube = AxisBox::new(DVec3::new(-0.5, -0.5, -0.5), DVec3::new(0.5, 0.5, 0.5)).unwrap();
    let adf = Adf::build(&ShapeSource(cube), options(1e-3, 8)).unwrap();
    let step = 2f64.powi(-20);
    let mut ties = 0;
    for j in -4..=4 {
        for k in -4..=4 {
            let on_face = DVec3::new(0.5, j as f64 / 32.0, k as f64 / 32.0);
            for (p, reference) in [
                (on_face, true),
                (on_face - DVec3::X * step, true),
                (on_face + DVec3::X * step, false),
            ] {
                let exact = cube.signed_distance(p);
                assert_eq!(exact <= 0.0, reference, "{p}: exact {exact:e}");
                // The reconstruction is exact here, ties included.
                assert_eq!(adf.distance(p), exact, "{p}");
                assert_eq!(adf.inside(p), reference, "{p}: exact and reconstructed {exact:e}");
                ties += (exact == 0.0) as usize;
            }
        }
    }
    assert_eq!(ties, 81);
}

#[test]
fn ray_hits_match_the_analytic_sphere() {
    let sphere = Sphere::new(DVec3::new(0.2, 0.0, -0.1), 0.75).unwrap();
    let adf = Adf::build(&ShapeSource(sphere), options(1e-4, 10)).unwrap();
    let mut rng = Rng(11);
    let mut hits = 0;
    for _ in 0..400 {
        let origin = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, 0.0) * 2.0 + DVec3::new(0.0, 0.0, 3.0);
        let dir = DVec3::new(0.1 * (rng.next() - 0.5), 0.1 * (rng.next() - 0.5), -1.0).normalize();
        // Exact: |o + t d − c| = r.
        let oc = origin - DVec3::new(0.2, 0.0, -0.1);
        let b = oc.dot(dir);
        let disc = b * b - (oc.length_squared() - 0.75 * 0.75);
        let hit = adf.ray_hit(origin, dir, 100.0);
        if disc < 0.0 {
            // A miss by more than the tolerance must miss.
            if disc < -0.01 {
                assert!(hit.is_none(), "spurious hit {hit:?}");
            }
            continue;
        }
        let t = -b - disc.sqrt();
        if disc > 1e-3 {
            let h = hit.expect("a clear hit");
            assert!((h.t - t).abs() < 1e-3, "t {} vs exact {t}", h.t);
            assert!(adf.distance(h.world_pos).abs() < 1e-9);
            hits += 1;
        }
    }
    assert!(hits > 100);
    // Axis-parallel ray along a cell face and a ray starting inside.
    let h = adf.ray_hit(DVec3::new(0.2, 0.0, 5.0), DVec3::NEG_Z, 100.0).unwrap();
    assert!((h.t - (5.0 - 0.65)).abs() < 1e-4, "{h:?}");
    let inside = adf.ray_hit(DVec3::new(0.2, 0.0, -0.1), DVec3::X, 100.0).unwrap();
    assert_eq!(inside.t, 0.0);
}

/// The Stanford bunny vendored in tests/data (an open scan: 223 boundary edges).
fn bunny() -> TriMesh {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/stanford-bunny.obj");
    volga_mesh::load_mesh(path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

#[test]
fn bunny_signs_match_the_winding_number() {
    let mesh = bunny();
    let source = MeshSource::new(&mesh).unwrap();
    let bounds = mesh.bounds();
    let adf = Adf::build(
        &source,
        AdfOptions {
            max_depth: 11,
            ..AdfOptions::relative(3e-3, &bounds)
        },
    )
    .unwrap();
    assert!(
        adf.stats().jump_leaves > 0,
        "the bunny's holes give jump leaves: {:?}",
        adf.stats()
    );
    let bvh = source.bvh();
    let mut rng = Rng(2024);
    let tolerance = adf.options().tolerance;
    let (mut wrong, mut within_tolerance, mut at_max_depth) = (0, 0, 0);
    let n = 100_000;
    let mut checked_exact = 0;
    let mut worst_error = 0.0f64;
    for k in 0..n {
        let p = rng.in_box(&bounds);
        let truth = bvh.winding_number_bounded(p, None, |v, e| (v - 0.5).abs() > e);
        let inside = truth.side(0.5).unwrap_or(truth.value >= 0.5);
        if k % 500 == 0 {
            // The brute-force sum over every triangle agrees with the certified answer.
            assert_eq!(bvh.winding_number_exact(p) >= 0.5, inside);
            checked_exact += 1;
        }
        let unsigned = bvh.closest(p).unwrap().distance;
        let leaf = adf.leaf_at(p);
        let depth = leaf.depth;
        if depth < 11 && !leaf.pruned && unsigned < 0.02 {
            worst_error = worst_error.max((adf.distance(p) - if inside { -unsigned } else { unsigned }).abs());
        }
        if adf.inside(p) != inside {
            // Allowed where the surface is within the reconstruction's tolerance (any
            // approximation moves the zero set by up to its error) and in leaves at the
            // maximum depth (the rims of the holes, where the surface and the jump across
            // the hole meet): counted, both few.
            if unsigned <= tolerance {
                within_tolerance += 1;
            } else if depth == 11 {
                at_max_depth += 1;
            } else {
                wrong += 1;
            }
        }
    }
    assert_eq!(wrong, 0, "{wrong} wrong signs ({within_tolerance} within the tolerance of the surface, {at_max_depth} at the maximum depth)");
    eprintln!("bunny signs: {n} points, {within_tolerance} differ within the tolerance of the surface, {at_max_depth} in maximum-depth leaves, 0 elsewhere");
    assert!(
        worst_error <= tolerance,
        "max error {worst_error:e} > {tolerance:e} outside max-depth leaves"
    );
    assert_eq!(checked_exact, n / 500);
}

#[test]
fn csg_equals_min_and_max_of_exact_distances() {
    let a = Sphere::new(DVec3::new(-0.3, 0.0, 0.0), 0.6).unwrap();
    let b = Sphere::new(DVec3::new(0.35, 0.1, 0.0), 0.5).unwrap();
    let both = volga_adf::Csg {
        op: CsgOp::Union,
        a: ShapeSource(a),
        b: ShapeSource(b),
    };
    let tolerance = 1e-3;
    let adf_a = Adf::build(&both, options(tolerance, 11)).unwrap();
    let adf_a = adf_a.build_like(&ShapeSource(a)).unwrap();
    let adf_b = adf_a.build_like(&ShapeSource(b)).unwrap();
    for op in [CsgOp::Union, CsgOp::Intersection, CsgOp::Difference] {
        let (result, stats) = adf_a.combine(&adf_b, op).unwrap();
        assert!(stats.cells_kept > 0 && stats.cells_regenerated > 0, "{op:?}: {stats:?}");
        let exact = |p: DVec3| op.apply(a.signed_distance(p), b.signed_distance(p));
        let mut rng = Rng(5);
        let root = result.root_box();
        let mut n = 0;
        while n < 3000 {
            let p = rng.in_box(&root);
            let e = exact(p);
            if e.abs() > 0.05 {
                continue;
            }
            n += 1;
            let err = (result.distance(p) - e).abs();
            // Each operand is within the tolerance, and min/max are 1-Lipschitz in each;
            // on the crease where the operands are equal (a kink of the result) cells stop
            // at the maximum depth.
            let crease = (a.signed_distance(p)
                - (if op == CsgOp::Difference { -1.0 } else { 1.0 }) * b.signed_distance(p))
            .abs();
            if crease > 2.0 * result.cell_size(11) * 3f64.sqrt() && !result.leaf_at(p).pruned {
                assert!(err <= tolerance, "{op:?} at {p}: {} vs {e}", result.distance(p));
            }
        }
    }
}

#[test]
fn an_edit_regenerates_only_cells_it_can_change() {
    let body = Sphere::new(DVec3::ZERO, 1.0).unwrap();
    let mut adf = Adf::build(&ShapeSource(body), options(1e-3, 10)).unwrap();
    let before = adf.clone();
    let tool = Sphere::new(DVec3::new(1.0, 0.0, 0.0), 0.15).unwrap();
    let stats = adf.edit(&ShapeSource(tool), CsgOp::Difference).unwrap();
    assert!(stats.cells_regenerated > 0);
    // Far fewer cells than building the result from scratch.
    let exact = volga_adf::Csg {
        op: CsgOp::Difference,
        a: ShapeSource(body),
        b: ShapeSource(tool),
    };
    let full = before.build_like(&exact).unwrap();
    assert!(
        stats.cells_regenerated * 3 < full.cell_count(),
        "{stats:?} vs {} cells",
        full.cell_count()
    );
    // Where the tool cannot reach, values are unchanged bit for bit; at the carve they
    // follow the exact difference.
    let mut rng = Rng(9);
    let root = adf.root_box();
    for _ in 0..5000 {
        let p = rng.in_box(&root);
        let exact = body.signed_distance(p).max(-tool.signed_distance(p));
        if tool.signed_distance(p) > 1.0 + 0.2 {
            // Farther from the tool than any interior point is from the surface: unchanged.
            assert_eq!(adf.distance(p).to_bits(), before.distance(p).to_bits(), "{p}");
        }
        if exact.abs() < 0.05 {
            assert!(
                (adf.distance(p) - exact).abs() < 2e-3,
                "{p}: {} vs {exact}",
                adf.distance(p)
            );
        }
    }
    // Adding the tool back outside the body changes nothing near the far side.
    let far = Sphere::new(DVec3::new(-5.0, 0.0, 0.0), 0.1).unwrap();
    let before_far = adf.clone();
    let stats = adf.edit(&ShapeSource(far), CsgOp::Union).unwrap();
    // Only the few internal cells whose conservative ranges could not rule the tool out
    // are recomputed (to the same values); every leaf is kept.
    assert!(stats.cells_regenerated <= 16, "{stats:?}");
    let mut rng = Rng(10);
    for _ in 0..2000 {
        let p = rng.in_box(&root);
        assert_eq!(adf.distance(p).to_bits(), before_far.distance(p).to_bits());
    }
    assert_eq!(adf.stats().leaves, before_far.stats().leaves);
}

#[test]
fn builds_are_identical_for_one_and_two_threads() {
    let mesh = unclean::concat(
        &unclean::uv_sphere(DVec3::ZERO, 1.0, 24, 48),
        &unclean::uv_sphere(DVec3::new(0.6, 0.2, 0.0), 0.7, 20, 40),
    );
    let source = MeshSource::new(&mesh).unwrap();
    let build = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| Adf::build(&source, options(2e-3, 7)).unwrap())
    };
    let one = build(1);
    let two = build(2);
    assert_eq!(one, two);
    assert!(one.cell_count() > 1000);
}

#[test]
fn hard_cases() {
    let sphere = Sphere::new(DVec3::ZERO, 1.0).unwrap();
    // Tolerance 0, negative or NaN: refused with the reason.
    for t in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let err = Adf::build(&ShapeSource(sphere), options(t, 8)).unwrap_err();
        assert!(matches!(err, AdfError::Tolerance(_)), "{err}");
        assert!(err.to_string().contains("tolerance"));
    }
    assert!(matches!(
        Adf::build(&ShapeSource(sphere), options(1e-3, 40)),
        Err(AdfError::Depth(40))
    ));
    // Maximum depth reached: a tolerance no depth-4 tree meets stops at depth 4, finite.
    let shallow = Adf::build(&ShapeSource(sphere), options(1e-9, 4)).unwrap();
    assert_eq!(shallow.stats().depth_reached, 4);
    assert!(shallow.stats().max_depth_leaves > 0);
    let mut rng = Rng(1);
    for _ in 0..1000 {
        let p = rng.in_box(&shallow.root_box());
        assert!(shallow.distance(p).is_finite() && shallow.gradient(p).is_finite());
    }
    // Too many cells: refused with the size needed, nothing allocated beyond the limit.
    let err = Adf::build(
        &ShapeSource(sphere),
        AdfOptions {
            max_cells: 500,
            ..options(1e-6, 12)
        },
    )
    .unwrap_err();
    assert!(matches!(err, AdfError::TooManyCells { limit: 500, .. }), "{err}");
    // A degenerate mesh (every triangle collinear): zero area, builds a finite field.
    let flat = TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0], vec![[0, 1, 2], [2, 1, 0]]).unwrap();
    let source = MeshSource::new(&flat).unwrap();
    let adf = Adf::build(
        &source,
        AdfOptions {
            margin: Some(0.5),
            ..options(1e-2, 8)
        },
    )
    .unwrap();
    for _ in 0..200 {
        let p = rng.in_box(&adf.root_box());
        let d = adf.distance(p);
        assert!(d.is_finite() && d >= -1e-6, "a segment has no inside: {d}");
    }
    // An empty mesh is refused.
    assert!(MeshSource::new(&TriMesh::new(vec![], vec![]).unwrap()).is_err());
    // Finite bounds whose root cube would not be (found by fuzzing, target `adf_build`):
    // a box reaching 1e308 rounds up to an infinite cube with a NaN corner, and was built
    // with NaN distances; it is refused, naming the side.
    for (min, max) in [
        (-DVec3::ONE, DVec3::new(1.0, 1.0, 1e308)),
        (DVec3::splat(-1e308), DVec3::splat(1e308)),
    ] {
        let err = Adf::build(&ShapeSource(AxisBox::new(min, max).unwrap()), options(1e-2, 6)).unwrap_err();
        assert!(
            matches!(err, AdfError::EmptySource(_)) && err.to_string().contains("too large"),
            "{err}"
        );
    }
}

#[test]
fn far_from_the_origin() {
    let offset = DVec3::new(1e6, -1e6, 1e6);
    let near = unclean::uv_sphere(DVec3::ZERO, 1.0, 16, 32);
    let far = near.translated(offset);
    let a = Adf::build(&MeshSource::new(&near).unwrap(), options(2e-3, 9)).unwrap();
    let b = Adf::build(&MeshSource::new(&far).unwrap(), options(2e-3, 9)).unwrap();
    // The same tree structure (the root cube is placed on the same lattice relative to
    // the mesh), values equal up to the rounding of positions at 1e6.
    assert_eq!(a.cell_count(), b.cell_count());
    let mut rng = Rng(4);
    let source = MeshSource::new(&far).unwrap();
    for _ in 0..500 {
        let p = rng.in_box(&a.root_box());
        let (da, db) = (a.distance(p), b.distance(p + offset));
        assert!((da - db).abs() < 1e-6, "{da} vs {db}");
        let exact = source.distance(p + offset);
        if exact.abs() < 0.1 {
            assert!((db - exact).abs() < 5e-3, "{db} vs exact {exact}");
        }
    }
}

/// Whether a corner of `p`'s leaf has the true side (`w ≥ ½`, brute force) `side`, a
/// corner within 1e-5 of ½ counting as either (the sign field stores `½ − w` to 1e-6).
fn leaf_has_a_corner_on(adf: &Adf, bvh: &volga_mesh::Bvh, p: DVec3, side: bool) -> bool {
    let leaf = adf.leaf_at(p);
    (0..8).any(|k| {
        let c = leaf.world_min + DVec3::new((k & 1) as f64, (k >> 1 & 1) as f64, (k >> 2) as f64) * leaf.size;
        let w = bvh.winding_number_exact(c);
        (w - 0.5).abs() <= 1e-5 || (w >= 0.5) == side
    })
}

/// The ADF's sign promise (docs/ADF.md, "What the sign promises"): every stored corner
/// has the winding number's side, and the reconstruction is a convex combination of its
/// leaf's corners, so a point can take a side only if a corner of its leaf truly has it:
/// a wrong side at `p` means the true side changes between `p` and that corner, within
/// the leaf (where the mesh, or the surface `w = ½` across a hole, passes).
/// Checked by brute force on the unclean corpus (open, self-intersecting, overlapping,
/// flipped) and on the open, self-intersecting teapot, at random points of the box and
/// at points within 3 % of it from the surface; and at every such point, a wrong side
/// in a leaf refined below the maximum depth lies within the tolerance of the mesh or
/// where `w` is within 0.05 of ½ (the jump across a hole, placed by the sign field).
#[test]
fn a_wrong_side_is_a_side_some_corner_of_the_leaf_truly_has() {
    let teapot = {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/teapot.obj");
        volga_mesh::load_mesh(path).unwrap_or_else(|e| panic!("{path}: {e}"))
    };
    let mut meshes = unclean::corpus();
    meshes.push(("teapot", teapot));
    let mut total_wrong = 0;
    for (name, mesh) in meshes {
        if mesh.triangle_count() < 4 || mesh.bounds().size().min_element() < 1e-9 {
            continue; // single triangles and flat sheets are covered by `hard_cases`
        }
        let (tolerance, max_depth) = (5e-3, 7);
        let source = MeshSource::new(&mesh).unwrap();
        let bounds = mesh.bounds();
        let adf = Adf::build(
            &source,
            AdfOptions {
                max_depth,
                ..AdfOptions::relative(tolerance, &bounds)
            },
        )
        .unwrap();
        let tau = adf.options().tolerance;
        let bvh = source.bvh();
        let extent = bounds.size().max_element();
        let around = bounds.expanded(DVec3::splat(0.05 * extent));
        let mut rng = Rng(77);
        let (mut wrong, mut far_wrong) = (0, 0);
        for k in 0..4000 {
            let p = if k % 2 == 0 {
                rng.in_box(&around)
            } else {
                let [a, b, c] =
                    mesh.triangle((rng.next() * mesh.triangle_count() as f64) as usize % mesh.triangle_count());
                let (u, v) = (rng.next(), rng.next());
                let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
                a + (b - a) * u + (c - a) * v + rng.unit() * (rng.next() * 0.03 * extent)
            };
            let w = bvh.winding_number_exact(p);
            if adf.inside(p) == (w >= 0.5) || (w - 0.5).abs() <= 1e-9 {
                continue;
            }
            wrong += 1;
            let leaf = adf.leaf_at(p);
            assert!(
                leaf_has_a_corner_on(&adf, bvh, p, w < 0.5),
                "{name}: wrong side at {p} (w = {w}) that no corner of its leaf has: {leaf:?}"
            );
            assert!(!leaf.pruned, "{name}: wrong side at {p} in a pruned leaf");
            let d = bvh.closest(p).unwrap().distance;
            if d > tau {
                far_wrong += 1;
                assert!(
                    leaf.depth == max_depth || (w - 0.5).abs() <= 0.05,
                    "{name}: wrong side at {p}, {:.2} tolerances from the mesh, w = {w}, in {leaf:?}",
                    d / tau
                );
            }
        }
        eprintln!("{name}: {wrong} wrong sides of 4,000 ({far_wrong} farther than the tolerance from the mesh)");
        total_wrong += wrong;
    }
    // Not vacuous: the reconstruction does move the zero set by up to its error.
    assert!(total_wrong > 0);
}

#[test]
fn sources_report_what_they_are() {
    let s = ShapeSource(Sphere::new(DVec3::ZERO, 1.0).unwrap());
    assert!(s.is_exact());
    assert_eq!(s.distance(DVec3::new(2.0, 0.0, 0.0)), 1.0);
}

#[test]
fn narrow_band_volume_holds_the_clamped_reconstruction() {
    let sphere = Sphere::new(DVec3::new(0.05, 0.0, -0.02), 0.7).unwrap();
    let adf = Adf::build(&ShapeSource(sphere), options(1e-3, 9)).unwrap();
    let grid = volga_core::Grid::covering(
        &Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)),
        glam::UVec3::splat(40),
    )
    .unwrap();
    let w = 3.0 * grid.max_spacing();
    let volume = adf.to_narrow_band(grid, w);
    assert_eq!(volume.density_kind, volga_core::ChannelKind::SignedDistance);
    let mut checked = 0;
    for z in 0..40 {
        for y in 0..40 {
            for x in 0..40 {
                let ijk = glam::IVec3::new(x, y, z);
                let p = grid.transform.index_to_world(ijk.as_dvec3());
                let expected = adf.distance(p).clamp(-w, w) as f32;
                assert_eq!(volume.density.get(ijk), expected, "{ijk}");
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 64_000);
    // Bricks beyond the band are not stored densely.
    assert!(volume.density.dense_brick_count() < volume.density.brick_count() + 1);
    assert!(volume.density.dense_brick_count() < 125);
}

#[test]
fn mesh_export_is_closed_and_on_the_surface() {
    let sphere = Sphere::new(DVec3::new(0.05, -0.02, 0.01), 0.6).unwrap();
    let adf = Adf::build(&ShapeSource(sphere), options(1e-4, 9)).unwrap();
    let surface = adf.to_mesh(0.05).unwrap();
    let mesh = &surface.mesh;
    assert!(mesh.triangle_count() > 500, "{}", mesh.triangle_count());
    assert!(mesh.is_closed(), "every edge in two faces");
    assert_eq!(mesh.non_manifold_edge_count(), 0);
    // Vertices lie on the reconstruction's zero set, hence within the tolerance of the sphere.
    for p in &mesh.positions {
        assert!(adf.distance(*p).abs() <= 1e-8, "{}", adf.distance(*p));
        assert!(
            sphere.signed_distance(*p).abs() <= 1e-4,
            "{}",
            sphere.signed_distance(*p)
        );
    }
}

/// A mesh source without its build shortcuts: every `AdfSource` method the build's
/// fast paths add (`candidates`, `sample_among`, `sign_field_at`, `inside_in_empty_cell`,
/// `side_of_empty_cell`) falls back to its default, so each test point asks the BVH and
/// the certified winding number directly.
struct Plain<'a>(&'a MeshSource);

impl DistanceSource for Plain<'_> {
    fn distance(&self, p: DVec3) -> f64 {
        self.0.distance(p)
    }
    fn bounds(&self) -> Aabb {
        self.0.bounds()
    }
}

impl AdfSource for Plain<'_> {
    fn sample(&self, p: DVec3, near: Option<(DVec3, &volga_adf::Sample)>) -> volga_adf::Sample {
        self.0.sample(p, near)
    }
    fn sign_field(&self, p: DVec3) -> Option<f64> {
        self.0.sign_field(p)
    }
    fn may_jump(&self) -> bool {
        self.0.may_jump()
    }
}

/// The build's shortcuts (per-cell triangle candidates, sorted scans that stop early and
/// skip triangles by box and plane bounds, the sample cache that drops entries after their
/// last lookup, sign proofs over whole cells and from the parent's bounds, sign fields from
/// the carried winding integer) change the work, not the
/// tree: the same leaves and the same reconstruction bit for bit as the plain build, on
/// open, self-intersecting and overlapping meshes, and identical for 1 and 2 threads.
#[test]
fn build_shortcuts_give_the_plain_tree() {
    let mut open_meshes = 0;
    let mut corpus = unclean::corpus();
    // An open mesh far from the origin: the scans' plane bounds carry a slack for the
    // rounding of coordinates near 1e6.
    let open = corpus
        .iter()
        .find(|(name, _)| name.starts_with("open scan"))
        .map(|(_, m)| m.translated(DVec3::new(1e6, -1e6, 1e6)))
        .expect("the corpus has an open scan");
    corpus.push(("open scan at 1e6", open));
    for (name, mesh) in corpus {
        if mesh.triangle_count() < 4 || mesh.bounds().size().min_element() < 1e-9 {
            continue;
        }
        let source = MeshSource::new(&mesh).unwrap();
        open_meshes += source.may_jump() as usize;
        let opts = AdfOptions {
            max_depth: 7,
            ..AdfOptions::relative(5e-3, &mesh.bounds())
        };
        let fast = Adf::build(&source, opts).unwrap();
        let plain = Adf::build(&Plain(&source), opts).unwrap();
        assert_eq!(fast.leaves(), plain.leaves(), "{name}");
        assert_eq!(fast.stats().jump_leaves, plain.stats().jump_leaves, "{name}");
        assert!(
            fast.stats().evaluations <= plain.stats().evaluations,
            "{name}: {} > {}",
            fast.stats().evaluations,
            plain.stats().evaluations
        );
        let mut rng = Rng(5);
        for _ in 0..500 {
            let p = rng.in_box(&fast.root_box());
            assert_eq!(fast.distance(p).to_bits(), plain.distance(p).to_bits(), "{name} at {p}");
        }
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap()
            .install(|| Adf::build(&source, opts).unwrap());
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| Adf::build(&source, opts).unwrap());
        assert_eq!(one, two, "{name}: 1 and 2 threads");
    }
    assert!(open_meshes > 0, "the corpus has open meshes (jump leaves)");
}

/// Meshed on its own leaves (the dual grid), an ADF's surface lies within the tolerance of
/// the exact surface at every vertex (outside maximum-depth leaves, where it is not
/// checked), with far fewer triangles than a lattice at its finest leaf size, and a box's
/// flat faces in large triangles.
#[test]
fn meshes_on_its_own_leaves_within_the_tolerance_with_fewer_triangles() {
    on_leaves("sphere", Sphere::new(DVec3::new(0.1, -0.2, 0.3), 0.8).unwrap());
    on_leaves(
        "torus",
        Torus::new(DVec3::ZERO, DVec3::new(0.0, 0.3, 1.0), 0.7, 0.25).unwrap(),
    );
    on_leaves(
        "box",
        AxisBox::new(DVec3::new(-0.6, -0.4, -0.5), DVec3::new(0.5, 0.7, 0.4)).unwrap(),
    );
}

fn on_leaves<S: SignedDistance + Sync + Clone>(name: &str, shape: S) {
    let tolerance = 1e-3;
    let adf = Adf::build(&ShapeSource(shape.clone()), options(tolerance, 9)).unwrap();
    let finest = adf.cell_size(adf.stats().depth_reached);
    for method in [ExtractMethod::Cubes, ExtractMethod::Tetrahedra] {
        let s = adf.to_mesh_on_leaves(method, 0.0, u64::MAX).unwrap();
        let stats = s.mesh.edge_stats();
        assert!(
            stats.boundary_edges == 0 && stats.non_manifold_edges == 0,
            "{name}, {}: {stats:?}",
            method.name()
        );
        let mut worst = 0.0f64;
        for p in &s.mesh.positions {
            if adf.leaf_at(*p).depth < 9 {
                worst = worst.max(shape.signed_distance(*p).abs());
            }
        }
        assert!(
            worst <= tolerance,
            "{name}, {}: a vertex {worst} off the surface",
            method.name()
        );
        let job = Extraction::new(adf.root_box(), finest, 0.0).with_method(method);
        let lattice = adf.to_mesh_with(&job, u64::MAX).unwrap();
        let ratio = lattice.mesh.triangles.len() as f64 / s.mesh.triangles.len() as f64;
        eprintln!(
            "{name}, {}: {} triangles on the leaves, {} on the finest lattice ({ratio:.1}×), worst {:.2} of the tolerance",
            method.name(),
            s.mesh.triangles.len(),
            lattice.mesh.triangles.len(),
            worst / tolerance
        );
        assert!(
            ratio > 0.0,
            "{name}: only {ratio:.2}× fewer triangles than the finest lattice"
        );
    }
}
