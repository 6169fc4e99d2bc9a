//! The packed fast path (`packet.rs`) against the general path: the same image within
//! 1/255 per channel over many random views of two volumes (a CT-like phantom and a
//! noisy, holed blob on an anisotropic, far-from-origin grid), shaded DVR with early
//! termination on and off (iso-surfaces, which stay on the general path, bit for bit);
//! the same shaded samples; skipping on = off and 1 = 2 threads bit for bit; and the
//! fields and settings that must not take it.

mod common;

use common::{blob, phantom, Lcg};
use glam::{DVec3, Vec3, Vec4};
use volga_core::{Field, Filter, GradientMethod, NoProgress, Sampled};
use volga_render::{
    Camera, Image, Iso, Light, Mip, Mode, Projection, RenderSettings, RenderStats, Renderer, SurfaceColour,
    TransferFunction, Volume,
};

/// Largest channel difference allowed between the packed and the general path (one
/// step of an 8-bit image).
const TOLERANCE: f32 = 1.0 / 255.0;

fn transfer() -> TransferFunction {
    TransferFunction::new(vec![
        (0.0, Vec4::new(0.0, 0.0, 0.0, 0.0)),
        (0.1, Vec4::new(0.9, 0.6, 0.5, 0.0)),
        (0.3, Vec4::new(0.9, 0.6, 0.5, 0.05)),
        (0.45, Vec4::new(0.3, 0.8, 0.5, 0.5)),
        (0.6, Vec4::new(1.0, 0.3, 0.2, 0.2)),
        (1.0, Vec4::new(1.0, 1.0, 0.95, 0.9)),
    ])
    .unwrap()
}

fn modes() -> Vec<Mode> {
    vec![
        Mode::Iso(Iso {
            value: 0.5,
            colour: SurfaceColour::Constant(Vec3::new(0.85, 0.8, 0.7)),
        }),
        Mode::Volume(Volume::new(transfer(), false)),
    ]
}

/// Two lights (one coloured), shininess 32 by default; early termination as given.
fn settings(early_termination: bool) -> RenderSettings {
    let mut s = RenderSettings::new(40, 34);
    s.image.background = Vec4::ZERO;
    s.lighting.lights.push(Light {
        direction: DVec3::new(-0.3, 0.2, -1.0),
        colour: Vec3::new(0.4, 0.5, 0.9),
    });
    if !early_termination {
        s.sampling.early_termination_alpha = 2.0;
    }
    s
}

fn random_camera(rng: &mut Lcg, field: &dyn Field) -> Camera {
    let b = field.bounds();
    let centre = b.center() + (b.size() * 0.2) * DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
    let dir = loop {
        let d = DVec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
        if d.length() > 0.1 {
            break d.normalize();
        }
    };
    let radius = 0.5 * b.size().length();
    let projection = if rng.next() < 0.3 {
        Projection::Orthographic {
            height_world: radius * 2.0,
        }
    } else {
        Projection::Perspective {
            fov_y_deg: 25.0 + 30.0 * rng.next(),
        }
    };
    let distance = radius * (1.5 + 2.0 * rng.next());
    let up = if dir.y.abs() > 0.9 { DVec3::X } else { DVec3::Y };
    Camera::look_at(centre + dir * distance, centre, up, projection).unwrap()
}

fn draw<F: Field + ?Sized>(field: &F, cam: &Camera, mode: &Mode, s: &RenderSettings) -> (Image, RenderStats, bool) {
    match mode {
        Mode::Iso(i) => {
            let r = Renderer::new(field, i, s).unwrap();
            let (img, st) = r.render(cam, &NoProgress);
            (img, st, r.is_packed())
        }
        Mode::Volume(v) => {
            let r = Renderer::new(field, v, s).unwrap();
            let (img, st) = r.render(cam, &NoProgress);
            (img, st, r.is_packed())
        }
        Mode::Mip(m) => {
            let r = Renderer::new(field, m, s).unwrap();
            let (img, st) = r.render(cam, &NoProgress);
            (img, st, r.is_packed())
        }
        other => panic!("not used here: {other:?}"),
    }
}

fn max_diff(a: &Image, b: &Image) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (*p - *q).abs().max_element())
        .fold(0.0, f32::max)
}

fn bits(img: &Image) -> Vec<[u32; 4]> {
    img.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

/// Packed and general images agree within 1/255 per channel and count the same work,
/// over 10 random views per volume, mode and early-termination setting.
#[test]
fn packed_images_match_the_general_path() {
    let volumes = [("phantom", phantom()), ("blob", blob())];
    let mut rng = Lcg(7);
    let mut worst = 0.0f32;
    for (name, volume) in &volumes {
        let field = Sampled::new(volume, Filter::Trilinear);
        for early in [false, true] {
            let fast = settings(early);
            let mut general = fast.clone();
            general.sampling.packed_path = false;
            for view in 0..10 {
                let cam = random_camera(&mut rng, &field);
                for mode in modes() {
                    let (a, sa, packed) = draw(&field, &cam, &mode, &fast);
                    let (b, sb, not_packed) = draw(&field, &cam, &mode, &general);
                    assert!(!not_packed);
                    if let Mode::Iso(_) = mode {
                        // Iso-surfaces find exact crossings on their own packed path,
                        // compared with the general one in `tests/iso_packed.rs`.
                        assert!(packed);
                        continue;
                    }
                    assert!(packed, "{name} {mode:?}");
                    let d = max_diff(&a, &b);
                    worst = worst.max(d);
                    assert!(d <= TOLERANCE, "{name}, view {view}, {mode:?}, early {early}: {d}");
                    assert_eq!(sa.rays, sb.rays);
                    if !early {
                        // Whole packets read a few samples past a cell's end, never
                        // fewer than the general loop, and shade the same visible ones.
                        assert!(sa.samples >= sb.samples, "{name} view {view}");
                        assert_eq!(sa.gradient_evaluations, sb.gradient_evaluations, "{name} view {view}");
                    }
                }
            }
        }
    }
    eprintln!("largest channel difference packed vs general: {worst:e}");
    // The images are not trivially equal: the f32 shading differs a little somewhere.
    assert!(worst > 0.0);
}

/// The packed path skips exactly like it marches (skipping on = off bit for bit) and
/// gives the same bits with 1 and 2 threads.
#[test]
fn packed_images_are_deterministic_and_skipping_changes_nothing() {
    let volume = phantom();
    let field = Sampled::new(&volume, Filter::Trilinear);
    let mut rng = Lcg(99);
    for view in 0..4 {
        let cam = random_camera(&mut rng, &field);
        for mode in modes() {
            let s = settings(view % 2 == 0);
            let (a, sa, packed) = draw(&field, &cam, &mode, &s);
            assert!(packed, "{mode:?}");
            assert!(a.pixels.iter().any(|p| p.w > 0.0), "{mode:?}: empty image");
            let mut no_skip = s.clone();
            no_skip.sampling.empty_space_skipping = false;
            let (b, sb, _) = draw(&field, &cam, &mode, &no_skip);
            assert_eq!(bits(&a), bits(&b), "view {view} {mode:?}");
            assert!(sa.cells_skipped > 0 && sb.cells_skipped == 0);
            for threads in [1, 2] {
                let c = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| draw(&field, &cam, &mode, &s).0);
                assert_eq!(bits(&a), bits(&c), "{threads} threads, {mode:?}");
            }
        }
    }
}

/// Only trilinear, central-difference sampled volumes in 1D-transfer DVR take the
/// packed path; everything else (iso-surfaces included) renders as before.
#[test]
fn the_packed_path_is_taken_only_where_it_applies() {
    let volume = phantom();
    let cam = random_camera(&mut Lcg(3), &Sampled::new(&volume, Filter::Trilinear));
    let s = settings(true);
    let iso = &modes()[0];
    let dvr = &modes()[1];
    let trilinear = Sampled::new(&volume, Filter::Trilinear);
    assert!(draw(&trilinear, &cam, iso, &s).2); // see `tests/iso_packed.rs`
    assert!(draw(&trilinear, &cam, dvr, &s).2);
    // A projection has no packed loop.
    assert!(!draw(&trilinear, &cam, &Mode::Mip(Mip), &s).2);
    // Other filters and gradient methods do not pack.
    for field in [
        Sampled::new(&volume, Filter::CatmullRom),
        Sampled::new(&volume, Filter::Nearest),
        Sampled::new(&volume, Filter::Trilinear).with_gradient(GradientMethod::Analytic),
    ] {
        let voxels = field.voxels().expect("a sampled volume has voxels");
        assert!(voxels.filter != Filter::Trilinear || voxels.gradient != GradientMethod::CentralDifference);
        assert!(!draw(&field, &cam, iso, &s).2);
        assert!(!draw(&field, &cam, dvr, &s).2);
    }
    // Colour from the field: the general loop.
    let coloured = Mode::Volume(Volume::new(transfer(), true));
    assert!(!draw(&trilinear, &cam, &coloured, &s).2);
    // The knob.
    let mut off = s.clone();
    off.sampling.packed_path = false;
    assert!(!draw(&trilinear, &cam, dvr, &off).2);
    // More lights than the packed shading takes.
    let mut many = s.clone();
    many.lighting.lights = (0..9)
        .map(|k| Light {
            direction: DVec3::new(1.0, k as f64, 0.5),
            colour: Vec3::splat(0.1),
        })
        .collect();
    assert!(!draw(&trilinear, &cam, dvr, &many).2);
}
