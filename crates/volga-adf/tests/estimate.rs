//! The a-priori estimate of a build (`Adf::estimate`) against the builds themselves, the
//! cell limit that stops a build the estimate let through, and unbounded sources.

use glam::DVec3;
use volga_adf::{Adf, AdfError, AdfOptions, AdfSource, MeshSource, ShapeSource};
use volga_shapes::{AxisBox, Cylinder, Sphere, Torus};

fn options(tolerance: f64, max_depth: u8) -> AdfOptions {
    AdfOptions {
        tolerance,
        max_depth,
        max_cells: 50_000_000,
        margin: None,
        band: 0.0,
    }
}

/// The estimate is at least the cells built and at most `slack` times them.
fn check<S: AdfSource + ?Sized>(what: &str, source: &S, options: AdfOptions, slack: f64) {
    let estimate = Adf::estimate(source, &options).unwrap();
    let built = Adf::build(source, options).unwrap();
    let ratio = estimate.cells as f64 / built.cell_count() as f64;
    println!(
        "{what} tolerance {:e} depth {}: estimate {} cells, built {} ({ratio:.2}×)",
        options.tolerance,
        options.max_depth,
        estimate.cells,
        built.cell_count()
    );
    assert!(
        ratio >= 1.0,
        "{what}: the estimate {estimate:?} is below the build's {} cells",
        built.cell_count()
    );
    assert!(
        ratio <= slack,
        "{what}: the estimate {estimate:?} is {ratio:.1}× the build's {} cells",
        built.cell_count()
    );
    assert!(built.stats().depth_reached <= estimate.deepest_split + 1);
}

#[test]
fn estimate_covers_the_build_of_shapes() {
    let sphere = ShapeSource(Sphere::new(DVec3::new(0.1, -0.2, 0.3), 0.8).unwrap());
    let cube = ShapeSource(AxisBox::new(DVec3::splat(-0.5), DVec3::splat(0.5)).unwrap());
    let torus = ShapeSource(Torus::new(DVec3::ZERO, DVec3::Z, 0.6, 0.2).unwrap());
    for tolerance in [1e-2, 1e-3, 1e-4] {
        check("sphere", &sphere, options(tolerance, 10), 8.0);
        // A cube's curvature is all on its edges, so only cells along them split; the
        // model counts the whole shell near its faces: the estimate grows with the
        // tolerance where the build stays put (measured 1.4×, 3.2×, 15×).
        check("cube", &cube, options(tolerance, 8), 20.0);
        check("torus", &torus, options(tolerance, 9), 8.0);
    }
    // With a band the pruning stops farther out: more cells, and the estimate follows.
    check(
        "sphere with a band",
        &sphere,
        AdfOptions {
            band: 0.05,
            ..options(1e-3, 9)
        },
        8.0,
    );
}

#[test]
fn estimate_covers_the_build_of_meshes() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
    for (name, tolerances) in [("fandisk.obj", [1e-2, 1e-3]), ("spot.obj", [1e-2, 1e-3])] {
        let mesh = volga_mesh::load_mesh(dir.join(name)).unwrap();
        let source = MeshSource::new(&mesh).unwrap();
        let diagonal = mesh.bounds().size().length();
        for fraction in tolerances {
            check(name, &source, options(fraction * diagonal, 12), 8.0);
        }
    }
}

#[test]
fn a_build_past_its_cell_limit_stops_with_the_size() {
    // Regression (issue 28): a fine tolerance ran on until memory ran out. The build now
    // stops at `max_cells` and says how much it would have held.
    let sphere = ShapeSource(Sphere::new(DVec3::ZERO, 1.0).unwrap());
    let opts = AdfOptions {
        max_cells: 10_000,
        ..options(1e-9, 14)
    };
    let estimate = Adf::estimate(&sphere, &opts).unwrap();
    assert!(estimate.cells > 1_000_000, "{estimate:?}");
    match Adf::build(&sphere, opts).unwrap_err() {
        AdfError::TooManyCells { limit, bytes } => {
            assert_eq!(limit, 10_000);
            assert!(bytes > 10_000 * volga_adf::BUILD_BYTES_PER_CELL);
        }
        e => panic!("{e}"),
    }
}

#[test]
fn unbounded_sources_are_named_as_such() {
    // Regression (issue 28): an infinite cylinder was refused as a bad tolerance
    // ("got inf"), from the tolerance relative to its infinite diagonal.
    let cylinder = ShapeSource(Cylinder::new(DVec3::ZERO, DVec3::Z, 1.0, None).unwrap());
    for err in [
        Adf::build(&cylinder, options(1e-3, 8)).unwrap_err(),
        Adf::estimate(&cylinder, &options(f64::INFINITY, 8)).unwrap_err(),
        Adf::build(&cylinder, options(f64::INFINITY, 8)).unwrap_err(),
    ] {
        assert!(matches!(err, AdfError::Unbounded { .. }), "{err}");
        assert!(err.to_string().contains("unbounded"), "{err}");
    }
}

/// A progress that records what it is told.
#[derive(Default)]
struct Recorded {
    starts: std::sync::Mutex<Vec<(String, u64)>>,
    done: std::sync::atomic::AtomicU64,
    finished: std::sync::atomic::AtomicBool,
}

impl volga_core::Progress for Recorded {
    fn start(&self, stage: &str, total: u64) {
        self.starts.lock().unwrap().push((stage.to_owned(), total));
    }
    fn inc(&self, n: u64) {
        self.done.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
    }
    fn finish(&self) {
        self.finished.store(true, std::sync::atomic::Ordering::Relaxed);
    }
}

#[test]
fn a_build_reports_its_progress_in_cells() {
    // Regression (issue 28): ADF builds showed no progress at all.
    let sphere = ShapeSource(Sphere::new(DVec3::ZERO, 1.0).unwrap());
    let opts = options(1e-4, 10);
    let estimate = Adf::estimate(&sphere, &opts).unwrap();
    let progress = Recorded::default();
    let adf = Adf::build_with_progress(&sphere, opts, &progress).unwrap();
    assert_eq!(
        *progress.starts.lock().unwrap(),
        vec![("adf cells".to_owned(), estimate.cells)]
    );
    let done = progress.done.load(std::sync::atomic::Ordering::Relaxed);
    assert!(
        done > 0 && done <= adf.cell_count() as u64,
        "{done} of {}",
        adf.cell_count()
    );
    assert!(progress.finished.load(std::sync::atomic::Ordering::Relaxed));
    // The same tree as without progress.
    assert_eq!(adf, Adf::build(&sphere, opts).unwrap());
}
