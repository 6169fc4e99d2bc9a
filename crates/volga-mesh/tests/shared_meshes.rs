//! The test meshes vendored in tests/data: counts from its README, and the BVH's
//! queries against brute force on real geometry.

use std::path::PathBuf;
use std::sync::OnceLock;

use glam::DVec3;
use volga_core::Aabb;
use volga_mesh::{load_obj, point_triangle_distance_squared, signed_distance, triangle_box_overlap, Bvh, TriMesh};

const DATA_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data");

/// The mesh, loaded once per test binary.
fn shared(name: &'static str) -> &'static TriMesh {
    static CACHE: OnceLock<std::sync::Mutex<Vec<(&'static str, &'static TriMesh)>>> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    let mut cache = cache.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, mesh)) = cache.iter().find(|(n, _)| *n == name) {
        return mesh;
    }
    let path = PathBuf::from(DATA_DIR).join(name);
    let mesh: &'static TriMesh = Box::leak(Box::new(
        load_obj(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    ));
    cache.push((name, mesh));
    mesh
}

/// A small deterministic generator (xorshift64*), so the sample points are fixed.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn point_in(&mut self, b: &Aabb) -> DVec3 {
        b.min + DVec3::new(self.unit(), self.unit(), self.unit()) * b.size()
    }
}

fn padded_bounds(mesh: &TriMesh, fraction: f64) -> Aabb {
    let b = mesh.bounds();
    b.expanded(b.size() * fraction)
}

#[test]
fn meshes_match_the_data_readme() {
    // (file, triangles, boundary edges after welding, by the file's vertex indices).
    // The README counts by vertex index. Only the teapot differs: its patches repeat
    // the positions along their seams, so 876 of its 1,036 index-boundary edges are
    // seams and 160 are real holes (the rims of its open parts).
    let expected = [
        ("stanford-bunny.obj", 69_451, 223, 223),
        ("spot.obj", 5_856, 0, 0),
        ("fandisk.obj", 12_946, 0, 0),
        ("rocker-arm.obj", 20_088, 0, 0),
        ("teapot.obj", 6_320, 160, 1_036),
    ];
    for (name, triangles, boundary_edges, unwelded_boundary_edges) in expected {
        let mesh = shared(name);
        let stats = mesh.edge_stats();
        eprintln!("{name}: {} triangles, {stats:?}", mesh.triangle_count());
        assert_eq!(mesh.triangle_count(), triangles, "{name}");
        assert_eq!(stats.boundary_edges, boundary_edges, "{name}");
        assert_eq!(stats.unwelded_boundary_edges, unwelded_boundary_edges, "{name}");
        assert_eq!(stats.non_manifold_edges, 0, "{name}");
        assert_eq!(mesh.degenerate_triangle_count(), 0, "{name}");
        assert_eq!(mesh.is_closed(), boundary_edges == 0, "{name}");
    }
}

/// Max and mean |fast − exact| over `count` points, asserting the inside/outside
/// classification agrees wherever the exact value is clear of ½ (by 0.1, above the
/// largest error measured).
fn winding_errors(mesh: &TriMesh, count: usize, seed: u64) -> (f64, f64) {
    let bvh = Bvh::build(mesh);
    let sample_box = padded_bounds(mesh, 0.1);
    let mut rng = Rng(seed);
    let (mut max_error, mut sum_error) = (0.0f64, 0.0);
    for _ in 0..count {
        let p = rng.point_in(&sample_box);
        let fast = bvh.winding_number(p);
        let exact = bvh.winding_number_exact(p);
        let error = (fast - exact).abs();
        max_error = max_error.max(error);
        sum_error += error;
        if (exact - 0.5).abs() > 0.1 {
            assert_eq!(
                fast >= 0.5,
                exact >= 0.5,
                "classification at {p}: fast {fast}, exact {exact}"
            );
        }
    }
    (max_error, sum_error / count as f64)
}

#[test]
fn fast_winding_number_matches_exact_on_spot() {
    let spot = shared("spot.obj");
    let (max_error, mean_error) = winding_errors(spot, 400, 1);
    eprintln!("spot: fast winding number error max {max_error:.2e}, mean {mean_error:.2e}");
    assert!(
        mean_error < 1e-2 && max_error < 0.1,
        "mean {mean_error}, max {max_error}"
    );
    // Closed: the exact value is an integer off the surface.
    let bvh = Bvh::build(spot);
    let mut rng = Rng(7);
    for _ in 0..100 {
        let p = rng.point_in(&padded_bounds(spot, 0.1));
        let w = bvh.winding_number_exact(p);
        if bvh.closest(p).unwrap().distance > 1e-3 {
            assert!(
                (w - w.round()).abs() < 1e-9 && (w.round() == 0.0 || w.round() == 1.0),
                "w = {w} at {p}"
            );
        }
    }
}

#[test]
fn fast_winding_number_matches_exact_on_the_bunny() {
    let bunny = shared("stanford-bunny.obj");
    let (max_error, mean_error) = winding_errors(bunny, 300, 2);
    eprintln!("bunny: fast winding number error max {max_error:.2e}, mean {mean_error:.2e}");
    assert!(
        mean_error < 1e-2 && max_error < 0.1,
        "mean {mean_error}, max {max_error}"
    );
}

#[test]
fn closest_matches_brute_force_on_spot() {
    let spot = shared("spot.obj");
    let bvh = Bvh::build(spot);
    let mut rng = Rng(3);
    let sample_box = padded_bounds(spot, 0.3);
    for _ in 0..200 {
        let p = rng.point_in(&sample_box);
        let brute = (0..spot.triangle_count())
            .map(|i| point_triangle_distance_squared(p, spot.triangle(i)))
            .fold(f64::INFINITY, f64::min);
        let c = bvh.closest(p).unwrap();
        assert_eq!(c.distance, brute.sqrt(), "at {p}");
        assert_eq!((c.point - p).length(), c.distance);
        assert_eq!(
            point_triangle_distance_squared(p, spot.triangle(c.triangle as usize)),
            brute
        );
        // A bound just below the distance finds nothing; at the distance, the same point.
        assert!(bvh.closest_within(p, c.distance * (1.0 - 1e-12)).is_none());
        assert_eq!(bvh.closest_within(p, c.distance).map(|w| w.distance), Some(c.distance));
    }
}

#[test]
fn overlapping_triangles_match_brute_force_on_the_bunny() {
    let bunny = shared("stanford-bunny.obj");
    let bvh = Bvh::build(bunny);
    let bounds = bunny.bounds();
    let mut rng = Rng(5);
    let mut found = Vec::new();
    let mut total = 0;
    for _ in 0..40 {
        let center = rng.point_in(&bounds);
        let half = bounds.size() * (0.002 + 0.05 * rng.unit());
        let query = Aabb::new(center - half, center + half);
        bvh.triangles_overlapping(&query, &mut found);
        let brute: Vec<u32> = (0..bunny.triangle_count() as u32)
            .filter(|&i| triangle_box_overlap(bunny.triangle(i as usize), &query))
            .collect();
        assert_eq!(found, brute);
        total += found.len();
    }
    assert!(total > 100, "the boxes should touch the surface sometimes ({total})");
}

#[test]
fn bvh_is_identical_for_any_thread_count() {
    let bunny = shared("stanford-bunny.obj");
    let build_with = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| Bvh::build(bunny))
    };
    let one = build_with(1);
    assert_eq!(one, build_with(2));
    assert_eq!(one, build_with(3));
}

#[test]
fn signed_distance_on_the_open_bunny_follows_the_winding_number() {
    let bunny = shared("stanford-bunny.obj");
    assert!(!bunny.is_closed());
    let bvh = Bvh::build(bunny);
    let mut rng = Rng(11);
    let sample_box = padded_bounds(bunny, 0.05);
    let mut inside = 0;
    for _ in 0..100 {
        let p = rng.point_in(&sample_box);
        let d = signed_distance(&bvh, p);
        assert_eq!(d.abs(), bvh.closest(p).unwrap().distance);
        let exact = bvh.winding_number_exact(p);
        if (exact - 0.5).abs() > 0.1 {
            assert_eq!(d < 0.0, exact >= 0.5, "at {p}");
        }
        inside += (d < 0.0) as usize;
    }
    assert!(inside > 0, "some samples fall inside the bunny");
}

/// The certified bound of `winding_number_bounded` contains the exact sum, on the first
/// pass and after refining to a threshold, at random points and at points just off the
/// surface (where the nearest leaves are summed exactly).
fn bounded_winding_contains_exact(mesh: &TriMesh, count: usize, seed: u64) {
    let bvh = Bvh::build(mesh);
    let sample_box = padded_bounds(mesh, 0.1);
    let mut rng = Rng(seed);
    let (mut first_certain, mut refined) = (0, 0);
    for k in 0..count {
        let mut p = rng.point_in(&sample_box);
        if k % 2 == 1 {
            // Near the surface: 1e-3 of the box size off the nearest point.
            let c = bvh.closest(p).unwrap();
            p = c.point + (p - c.point).normalize_or_zero() * 1e-3 * sample_box.size().max_element();
        }
        let exact = bvh.winding_number_exact(p);
        let first = bvh.winding_number_bounded(p, None, |_, _| true);
        assert!(
            (first.value - exact).abs() <= first.error,
            "first pass at {p}: {first:?}, exact {exact}"
        );
        first_certain += first.side(0.5).is_some() as usize;
        let decided = bvh.winding_number_bounded(p, None, |w, e| (w - 0.5).abs() > e);
        assert!(
            (decided.value - exact).abs() <= decided.error,
            "{decided:?}, exact {exact}"
        );
        refined += (decided.refinements > 0) as usize;
        if (exact - 0.5).abs() > 1e-9 {
            assert_eq!(decided.side(0.5), Some(exact >= 0.5), "{decided:?}, exact {exact}");
        }
        let tight = bvh.winding_number_bounded(p, None, |_, e| e < 1e-6);
        assert!(tight.error < 1e-6 && (tight.value - exact).abs() <= tight.error);
    }
    eprintln!("certified on the first pass: {first_certain} of {count}; refined: {refined}");
}

#[test]
fn bounded_winding_number_is_certified_on_spot_and_the_bunny() {
    bounded_winding_contains_exact(shared("spot.obj"), 200, 3);
    bounded_winding_contains_exact(shared("stanford-bunny.obj"), 60, 4);
}
