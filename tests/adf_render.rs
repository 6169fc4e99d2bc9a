//! An ADF renders through the raycaster like any field: its iso-surface image matches the
//! exact distance field's, and cell-level ranges skip empty space.

use glam::{DVec3, Vec3};
use volga::adf::{Adf, AdfOptions, ShapeSource};
use volga::core::{Field, NoProgress};
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
    let (a, stats) = render(&adf, &camera, &mode, &settings, &NoProgress).unwrap();
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
    assert!(stats.cells_skipped > 0, "empty space skipped by cell ranges");
}
