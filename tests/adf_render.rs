//! An ADF renders through the raycaster like any field: its iso-surface image matches the
//! exact distance field's, and cell-level ranges skip empty space.

use glam::{DVec3, Vec3};
use volga::adf::{Adf, AdfOptions, ShapeSource};
use volga::core::{Aabb, Crossing, Field, FieldKind, Line, NoProgress};
use volga::render::{render, Camera, Iso, Mode, Projection, RenderSettings, SurfaceColour};
use volga::shapes::{DistanceField, Sphere};

#[test]
fn adf_iso_image_matches_the_exact_sphere() {
    let sphere = Sphere::new(DVec3::new(0.1, -0.05, 0.0), 0.6).unwrap();
    let adf = Adf::build(
        &ShapeSource(sphere),
        AdfOptions {
            tolerance: 1e-4,
            max_depth: 10,
            ..AdfOptions::default()
        },
    )
    .unwrap();
    let exact = DistanceField::new(sphere, 0.3, adf.sample_spacing());
    assert_eq!(exact.kind(), adf.kind());
    let camera = Camera::look_at(
        DVec3::new(0.0, 0.5, 3.0),
        DVec3::ZERO,
        DVec3::Y,
        Projection::Perspective { fov_y_deg: 35.0 },
    )
    .unwrap();
    let settings = RenderSettings::new(96, 96);
    let mode = Mode::Iso(Iso {
        value: 0.0,
        colour: SurfaceColour::Constant(Vec3::ONE),
    });
    let (a, _) = render(&adf, &camera, &mode, &settings, &NoProgress).unwrap();
    let (_, stats) = render(&Marched(&adf), &camera, &mode, &settings, &NoProgress).unwrap();
    let (b, _) = render(&exact, &camera, &mode, &settings, &NoProgress).unwrap();
    let mut coverage_differs = 0;
    let mut covered = 0;
    for (pa, pb) in a.pixels.iter().zip(&b.pixels) {
        let (ha, hb) = (pa.w > 0.5, pb.w > 0.5);
        covered += ha as usize;
        if ha != hb {
            coverage_differs += 1;
        } else if ha {
            // Same shading up to the normal's error.
            assert!((*pa - *pb).abs().max_element() < 0.05, "{pa} vs {pb}");
        }
    }
    assert!(covered > 1000, "{covered}");
    assert!(coverage_differs <= 10, "{coverage_differs} silhouette pixels differ");
    assert!(stats.cells_skipped > 0, "marched: empty space skipped by cell ranges");
}

/// The ADF as a plain field: every method but [`Field::first_crossing`] forwarded, so the
/// renderer marches its sample lattice instead of asking the ADF's leaf walk.
struct Marched<'a>(&'a Adf);

impl Field for Marched<'_> {
    fn bounds(&self) -> Aabb {
        self.0.bounds()
    }
    fn kind(&self) -> FieldKind {
        self.0.kind()
    }
    fn background(&self) -> f64 {
        self.0.background()
    }
    fn value(&self, p: DVec3) -> f64 {
        self.0.value(p)
    }
    fn values_along(&self, line: &Line, first: u64, out: &mut [f64]) {
        self.0.values_along(line, first, out)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        Field::gradient(self.0, p)
    }
    fn gradient_step(&self) -> DVec3 {
        self.0.gradient_step()
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        self.0.value_range(b)
    }
    fn sample_spacing(&self) -> f64 {
        self.0.sample_spacing()
    }
}

/// The iso renderer takes an ADF's crossings from its own leaf walk (exact cubic roots in
/// each trilinear leaf) instead of marching samples: the image must be the marched one
/// up to where the marcher's sample spacing misses thin slivers (silhouette pixels) and
/// the two root finders' last digits, and identical for 1 and 2 threads.
#[test]
fn adf_leaf_walk_image_equals_the_marched_image() {
    use volga::adf::{Csg, CsgOp};
    use volga::shapes::{AxisBox, Torus};
    let torus = Torus::new(DVec3::ZERO, DVec3::new(0.0, 0.3, 1.0), 0.6, 0.2).unwrap();
    let cube = AxisBox::new(DVec3::new(-0.3, -0.3, -0.3), DVec3::new(0.3, 0.3, 0.3)).unwrap();
    let source = Csg {
        op: CsgOp::Union,
        a: ShapeSource(torus),
        b: ShapeSource(cube),
    };
    let adf = Adf::build(
        &source,
        AdfOptions {
            tolerance: 1e-3,
            max_depth: 8,
            ..AdfOptions::default()
        },
    )
    .unwrap();
    let camera = Camera::look_at(
        DVec3::new(1.2, 1.4, 2.6),
        DVec3::ZERO,
        DVec3::Y,
        Projection::Perspective { fov_y_deg: 40.0 },
    )
    .unwrap();
    let settings = RenderSettings::new(80, 80);
    let mode = Mode::Iso(Iso {
        value: 0.0,
        colour: SurfaceColour::Constant(Vec3::ONE),
    });
    assert!(matches!(
        adf.first_crossing(DVec3::new(0.0, 0.0, 3.0), DVec3::NEG_Z, 0.0, 6.0, 0.0),
        Crossing::At(_)
    ));
    let pool = |n: usize| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let walked = |n: usize| pool(n).install(|| render(&adf, &camera, &mode, &settings, &NoProgress).unwrap().0);
    let (a, a2) = (walked(1), walked(2));
    assert_eq!(a.pixels, a2.pixels, "1 and 2 threads");
    let (b, stats) = render(&Marched(&adf), &camera, &mode, &settings, &NoProgress).unwrap();
    assert!(stats.samples > 0);
    let mut covered = 0;
    let mut coverage_differs = 0;
    let mut shading_differs = 0;
    for (pa, pb) in a.pixels.iter().zip(&b.pixels) {
        let (ha, hb) = (pa.w > 0.5, pb.w > 0.5);
        covered += ha as usize;
        if ha != hb {
            coverage_differs += 1;
        } else if ha {
            shading_differs += ((*pa - *pb).abs().max_element() > 1e-3) as usize;
        }
    }
    assert!(covered > 1500, "{covered}");
    // The marcher can step over a crossing thinner than its sample spacing at a
    // silhouette; the walk cannot. Both refine the same reconstruction's root, so a pixel
    // both hit is shaded alike, except where the hit lies on a leaf face (the trilinear
    // gradient jumps there, and the two root finders' last digits pick either leaf) or
    // the marcher stepped over a sliver in front (2 pixels when this test was written).
    assert!(coverage_differs <= 8, "{coverage_differs} pixels differ in coverage");
    assert!(
        shading_differs <= 4,
        "{shading_differs} of {covered} pixels shaded differently"
    );
}
