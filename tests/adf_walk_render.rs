//! The indexed ADF walk in the raycaster: the image equals the reference walk's
//! (`volga::adf::DescentWalk`) and is the same bit for bit for 1 and 2 threads, from a
//! camera outside and from a camera inside the ADF.

use glam::{DVec3, Vec3};
use volga::adf::{Adf, AdfOptions, Csg, CsgOp, DescentWalk, OneRayWalk, ShapeSource};
use volga::core::NoProgress;
use volga::render::{render, Camera, Image, Iso, Mode, Projection, RenderSettings, SurfaceColour};
use volga::shapes::{AxisBox, Torus};

fn scene() -> Adf {
    let torus = ShapeSource(Torus::new(DVec3::new(0.0, 0.05, 0.0), DVec3::Y, 0.55, 0.18).unwrap());
    let cube = ShapeSource(AxisBox::new(DVec3::new(-0.2, -0.3, -0.2), DVec3::new(0.25, 0.2, 0.3)).unwrap());
    let source = Csg {
        op: CsgOp::Union,
        a: torus,
        b: cube,
    };
    Adf::build(
        &source,
        AdfOptions {
            tolerance: 1e-3,
            max_depth: 9,
            ..AdfOptions::default()
        },
    )
    .unwrap()
}

fn draw(field: &dyn volga::core::Field, eye: DVec3, threads: usize) -> Image {
    let camera = Camera::look_at(eye, DVec3::ZERO, DVec3::Y, Projection::Perspective { fov_y_deg: 50.0 }).unwrap();
    let mode = Mode::Iso(Iso {
        value: 0.0,
        colour: SurfaceColour::Constant(Vec3::new(0.9, 0.8, 0.7)),
    });
    let settings = RenderSettings::new(80, 80);
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| render(field, &camera, &mode, &settings, &NoProgress).unwrap().0)
}

fn bits(image: &Image) -> Vec<[u32; 4]> {
    image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

#[test]
fn indexed_walk_image_equals_the_reference_walk_for_any_thread_count() {
    // Outside the root cube (oblique); inside it but outside the surface; inside the
    // torus's tube (every ray starts inside: the whole image is covered).
    for eye in [
        DVec3::new(1.2, 1.0, 2.2),
        DVec3::new(0.1, 0.3, 0.9),
        DVec3::new(0.0, 0.05, 0.55),
    ] {
        let one = draw(&scene(), eye, 1);
        let two = draw(&scene(), eye, 2);
        assert_eq!(bits(&one), bits(&two), "1 and 2 threads differ from {eye:?}");
        let adf = scene();
        let reference = draw(&DescentWalk(&adf), eye, 2);
        let mut covered = 0;
        let mut differs = 0;
        for (a, b) in one.pixels.iter().zip(&reference.pixels) {
            covered += (a.w > 0.5) as usize;
            if (a.w > 0.5) != (b.w > 0.5) || (*a - *b).abs().max_element() > 1e-3 {
                differs += 1;
            }
        }
        assert!(covered > 500, "{covered} pixels covered from {eye:?}");
        // Hits on a leaf face may land in either leaf (the gradient jumps there).
        assert!(
            differs <= 4,
            "{differs} pixels differ from the reference walk from {eye:?}"
        );
    }
}

/// The renderer asks a tile's crossings at once (`Field::first_crossings`, the ADF's
/// batched walk): the image equals the one asked ray by ray bit for bit, with one ray per
/// pixel and with 2×2 and 8×8 supersampling (8×8 traces a tile in batches of at most
/// 4096 rays), tiles of 16 and of 7 pixels, iso 0 and 0.03, from
/// outside, inside the root cube and inside the surface, for 1 and 2 threads.
#[test]
fn batched_crossings_give_the_image_of_one_ray_at_a_time() {
    let adf = scene();
    for eye in [
        DVec3::new(1.2, 1.0, 2.2),
        DVec3::new(0.1, 0.3, 0.9),
        DVec3::new(0.0, 0.05, 0.55),
    ] {
        let camera = Camera::look_at(eye, DVec3::ZERO, DVec3::Y, Projection::Perspective { fov_y_deg: 50.0 }).unwrap();
        // The last case, 8×8 rays per pixel in a 16-pixel tile, traces a tile in batches
        // of at most 4096 rays.
        for (iso, supersampling, tile, (w, h)) in
            [(0.0, 1, 16, (61, 45)), (0.03, 2, 7, (61, 45)), (0.0, 8, 16, (12, 10))]
        {
            let mode = Mode::Iso(Iso {
                value: iso,
                colour: SurfaceColour::Constant(Vec3::new(0.9, 0.8, 0.7)),
            });
            let mut settings = RenderSettings::new(w, h);
            settings.image.supersampling = supersampling;
            settings.image.tile_size = tile;
            let image = |field: &dyn volga::core::Field, threads: usize| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| render(field, &camera, &mode, &settings, &NoProgress).unwrap())
            };
            let (batched, stats) = image(&adf, 2);
            let (one, one_stats) = image(&OneRayWalk(&adf), 1);
            assert_eq!(bits(&batched), bits(&one), "from {eye:?}, iso {iso}");
            assert_eq!(stats.rays, one_stats.rays);
            assert_eq!(stats.rays, (w * h * supersampling * supersampling) as u64);
            let covered = batched.pixels.iter().filter(|p| p.w > 0.5).count();
            assert!(covered * 6 > (w * h) as usize, "{covered} pixels covered from {eye:?}");
        }
    }
}
