//! Edge cases of the sampling path against exact answers: the X-ray of a constant box
//! is its path length (axis-parallel, oblique and grazing rays), a one-voxel volume,
//! a camera inside the volume, and a grid whose origin is at 10⁶.

use glam::{DVec3, IVec3, UVec3, Vec3, Vec4};
use volga_core::{Aabb, Field, Filter, Grid, NoProgress, Sampled, SparseVolume, Transform};
use volga_render::{
    first_hit, render, Camera, Image, Iso, Lighting, Mip, Mode, Projection, RenderSettings, RenderStats, SurfaceColour,
    TransferFunction, Volume, XRay,
};

/// Density 1 inside `inner`, 0 elsewhere, over `bounds`.
struct ConstBox {
    bounds: Aabb,
    inner: Aabb,
    spacing: f64,
}

impl Field for ConstBox {
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn value(&self, p: DVec3) -> f64 {
        if self.inner.contains(p) {
            1.0
        } else {
            0.0
        }
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.spacing)
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        if b.intersection(&self.inner).is_empty() {
            (0.0, 0.0)
        } else {
            (0.0, 1.0)
        }
    }
}

fn transparent(w: u32, h: u32) -> RenderSettings {
    let mut s = RenderSettings::new(w, h);
    s.image.background = Vec4::ZERO;
    s
}

fn go<F: Field + ?Sized>(field: &F, cam: &Camera, mode: &Mode, s: &RenderSettings) -> (Image, RenderStats) {
    render(field, cam, mode, s, &NoProgress).expect("renders")
}

fn bits(img: &Image) -> Vec<[u32; 4]> {
    img.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn length_inside(b: &Aabb, origin: DVec3, dir: DVec3) -> f64 {
    b.ray_interval(origin, dir).map_or(0.0, |(t0, t1)| t1 - t0)
}

/// The X-ray mode draws the mean value along the ray inside the bounds: for a box of
/// density 1, the fraction `L_box / L_bounds` of the ray's length. Lattice samples
/// count each length to within one step at each end, so the mean is within
/// `3·Δs / L_bounds` of it.
#[test]
fn xray_of_a_constant_box_is_its_path_length() {
    let field = ConstBox {
        bounds: Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)),
        inner: Aabb::new(DVec3::new(-1.0, -0.5, -0.75), DVec3::new(1.0, 0.5, 0.75)),
        spacing: 0.02,
    };
    let (w, h) = (33, 29);
    let s = transparent(w, h);
    let step = s.sampling.step_voxels * field.spacing;
    // The bounds' height, widened so the first and last rows of pixel centres lie on
    // the faces y = ±2 (up to rounding): grazing rays.
    let grazing_height = 4.0 / (1.0 - 1.0 / h as f64);
    let views = [
        (DVec3::new(0.0, 0.0, -6.0), 5.0),
        (DVec3::new(-6.0, 0.0, 0.0), grazing_height),
        (DVec3::new(4.0, 3.0, -5.0), 6.0),
        (DVec3::new(-1.0, 5.0, 0.5), 4.5),
    ];
    let mut inside_rays = 0;
    for (eye, height_world) in views {
        let up = if eye.x == 0.0 && eye.z == 0.0 {
            DVec3::Z
        } else {
            DVec3::Y
        };
        let cam = Camera::look_at(eye, DVec3::ZERO, up, Projection::Orthographic { height_world }).unwrap();
        let (img, _) = go(&field, &cam, &Mode::XRay(XRay), &s);
        for y in 0..h {
            for x in 0..w {
                let ray = cam.ray(x as f64, y as f64, w, h);
                let l_bounds = length_inside(&field.bounds, ray.origin, ray.dir);
                let alpha = img.get(x, y).w as f64;
                assert!(alpha.is_finite());
                if l_bounds < 4.0 * step {
                    continue; // a corner graze: too few samples for a ratio
                }
                let want = length_inside(&field.inner, ray.origin, ray.dir) / l_bounds;
                let tol = 3.0 * step / l_bounds + 1e-6;
                assert!(
                    (alpha - want).abs() <= tol,
                    "{eye} ({x}, {y}): {alpha} vs {want} ± {tol}"
                );
                inside_rays += (want > 0.0) as u32;
            }
        }
    }
    assert!(inside_rays > 300, "{inside_rays}");
}

/// A one-voxel volume (density 1, background 0) sampled trilinearly is the tent
/// `(1 − |x|)(1 − |y|)(1 − |z|)` in voxel units. Along the axis through its centre the
/// lattice `t0 + (i + ½)·½` samples z = ±0.25, ±0.75: MIP 0.75 and X-ray mean 0.5 exactly,
/// and the iso-surface 0.5 is hit at z = 0.5.
#[test]
fn a_one_voxel_volume() {
    let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::ONE).unwrap();
    let mut volume = SparseVolume::new(grid, 0.0, false);
    volume.density.set(IVec3::ZERO, 1.0);
    let field = Sampled::new(&volume, Filter::Trilinear);
    let cam = Camera::look_at(
        DVec3::new(0.0, 0.0, 5.0),
        DVec3::ZERO,
        DVec3::Y,
        Projection::Orthographic { height_world: 4.0 },
    )
    .unwrap();
    let s = transparent(1, 1);
    assert_eq!(go(&field, &cam, &Mode::Mip(Mip), &s).0.get(0, 0).w, 0.75);
    assert_eq!(go(&field, &cam, &Mode::XRay(XRay), &s).0.get(0, 0).w, 0.5);
    let iso = Mode::Iso(Iso {
        value: 0.5,
        colour: SurfaceColour::Constant(Vec3::ONE),
    });
    assert_eq!(go(&field, &cam, &iso, &s).0.get(0, 0).w, 1.0);
    let hit = first_hit(&field, &cam.ray(0.0, 0.0, 1, 1), 0.5, 0.5).unwrap();
    assert!((hit.world_pos - DVec3::new(0.0, 0.0, 0.5)).length() < 1e-9, "{hit:?}");
    // Larger images of it: finite, and the same with and without skipping.
    let mut s = transparent(16, 16);
    let modes = [iso.clone(), Mode::Mip(Mip), Mode::XRay(XRay), volume_mode()];
    for mode in &modes {
        let (on, _) = go(&field, &cam, mode, &s);
        s.sampling.empty_space_skipping = false;
        let (off, _) = go(&field, &cam, mode, &s);
        s.sampling.empty_space_skipping = true;
        assert_eq!(bits(&on), bits(&off), "{mode:?}");
        assert!(on.pixels.iter().all(|p| p.is_finite()));
    }
}

fn volume_mode() -> Mode {
    let tf = TransferFunction::new(vec![
        (0.0, Vec4::new(1.0, 0.5, 0.2, 0.0)),
        (0.5, Vec4::new(1.0, 0.8, 0.4, 0.3)),
        (1.0, Vec4::new(1.0, 1.0, 1.0, 0.05)),
    ])
    .unwrap();
    Mode::Volume(Volume::new(tf, false))
}

/// A ball of radius 7 voxels, density blended over 2 voxels, in a 24³ grid with voxel
/// (0, 0, 0) at `origin`.
fn ball(origin: DVec3) -> SparseVolume {
    ball_in(origin, 24, DVec3::splat(11.5))
}

fn ball_in(origin: DVec3, size: u32, centre: DVec3) -> SparseVolume {
    let grid = Grid::new(Transform::new(origin, DVec3::ONE).unwrap(), UVec3::splat(size)).unwrap();
    let mut volume = SparseVolume::new(grid, 0.0, false);
    for ijk in grid.index_box().iter() {
        let d = (ijk.as_dvec3() - centre).length() - 7.0;
        let v = (0.5 - d / 2.0).clamp(0.0, 1.0) as f32;
        if v > 0.0 {
            volume.density.set(ijk, v);
        }
    }
    volume
}

fn modes() -> [Mode; 4] {
    [
        Mode::Iso(Iso {
            value: 0.5,
            colour: SurfaceColour::Constant(Vec3::new(0.9, 0.6, 0.3)),
        }),
        volume_mode(),
        Mode::Mip(Mip),
        Mode::XRay(XRay),
    ]
}

/// Cameras inside the bounds, outside and inside the ball: every ray starts inside
/// the volume. Iso hits are those of `first_hit` (from the eye on), a camera inside the
/// solid sees no crossing into it, and skipping changes no bit.
#[test]
fn a_camera_inside_the_volume() {
    let volume = ball(DVec3::ZERO);
    let field = Sampled::new(&volume, Filter::Trilinear);
    let centre = DVec3::splat(11.5);
    let (w, h) = (24, 20);
    for (eye, look) in [
        (centre + DVec3::new(10.0, 1.0, -0.5), centre),
        (centre + DVec3::new(1.0, 0.5, 0.25), centre + DVec3::X * 5.0),
    ] {
        let cam = Camera::look_at(eye, look, DVec3::Y, Projection::Perspective { fov_y_deg: 90.0 }).unwrap();
        assert!(field.bounds().contains(eye));
        let eye_inside_solid = field.value(eye) >= 0.5;
        for mode in modes() {
            let mut s = transparent(w, h);
            let (on, _) = go(&field, &cam, &mode, &s);
            s.sampling.empty_space_skipping = false;
            let (off, _) = go(&field, &cam, &mode, &s);
            assert_eq!(bits(&on), bits(&off), "{mode:?}");
            assert!(on.pixels.iter().all(|p| p.is_finite()));
            if let Mode::Iso(_) = mode {
                let mut hits = 0;
                for y in 0..h {
                    for x in 0..w {
                        // A fine step: the image's packed path finds exact crossings,
                        // also those a 0.5-voxel step misses at grazing rays.
                        let hit = first_hit(&field, &cam.ray(x as f64, y as f64, w, h), 0.5, 1.0 / 64.0);
                        assert_eq!(on.get(x, y).w == 1.0, hit.is_some(), "({x}, {y})");
                        hits += hit.is_some() as u32;
                    }
                }
                if eye_inside_solid {
                    assert_eq!(hits, 0);
                } else {
                    assert!(hits > 100, "{hits}");
                }
            }
        }
    }
}

/// The same ball with voxel (0, 0, 0) at the origin and at 10⁶ on every axis, seen by
/// cameras moved by the same offset: the images agree to 1e-4 (positions keep
/// 10⁻¹⁰ of a voxel at 10⁶ in f64) and are finite.
#[test]
fn a_grid_far_from_the_origin_renders_like_one_at_it() {
    let offset = DVec3::splat(1e6);
    let near = ball(DVec3::ZERO);
    let far = ball(offset);
    let (fnear, ffar) = (
        Sampled::new(&near, Filter::Trilinear),
        Sampled::new(&far, Filter::Trilinear),
    );
    let centre = DVec3::splat(11.5);
    let s = transparent(32, 28);
    for eye in [DVec3::new(40.0, 25.0, -30.0), DVec3::new(0.0, 0.0, -40.0)] {
        let camera = |o: DVec3| {
            Camera::look_at(
                o + centre + eye,
                o + centre,
                DVec3::Y,
                Projection::Perspective { fov_y_deg: 40.0 },
            )
            .unwrap()
        };
        for mode in modes() {
            let (a, _) = go(&fnear, &camera(DVec3::ZERO), &mode, &s);
            let (b, _) = go(&ffar, &camera(offset), &mode, &s);
            assert!(b.pixels.iter().all(|p| p.is_finite()));
            let diff = a
                .pixels
                .iter()
                .zip(&b.pixels)
                .map(|(p, q)| (*p - *q).abs().max_element())
                .fold(0.0f32, f32::max);
            assert!(diff < 1e-4, "{mode:?}: {diff}");
            assert!(a.pixels.iter().any(|p| p.w > 0.0), "{mode:?}: empty image");
        }
    }
}

/// A small ball in a corner of a 128³ grid (16 macro cells a side): rays cross blocks of
/// empty cells in jumps. Every mode's image is the same with and without skipping, and
/// the jumps make fewer skip steps than there are empty cells along the rays.
#[test]
fn jumps_across_empty_space_change_nothing() {
    let volume = ball_in(DVec3::ZERO, 128, DVec3::new(100.0, 30.0, 90.0));
    let field = Sampled::new(&volume, Filter::Trilinear);
    let (w, h) = (40, 36);
    for (eye, up) in [
        (DVec3::new(-60.0, 140.0, -80.0), DVec3::Y),
        (DVec3::new(100.0, 30.0, -200.0), DVec3::Y),
        (DVec3::new(64.0, 300.0, 64.0), DVec3::Z),
    ] {
        let cam = Camera::look_at(
            eye,
            DVec3::new(100.0, 30.0, 90.0),
            up,
            Projection::Perspective { fov_y_deg: 20.0 },
        )
        .unwrap();
        for mode in modes() {
            let mut s = transparent(w, h);
            let (on, st_on) = go(&field, &cam, &mode, &s);
            s.sampling.empty_space_skipping = false;
            let (off, _) = go(&field, &cam, &mode, &s);
            assert_eq!(bits(&on), bits(&off), "{mode:?} from {eye}");
            assert!(on.pixels.iter().any(|p| p.w > 0.0), "{mode:?}: empty image");
            if let Mode::Iso(_) | Mode::Volume(_) = mode {
                // Rays cross ≥ 16 cells of the grid, nearly all empty; with jumps of up
                // to 8 cells they need a few skip steps each.
                assert!(st_on.cells_skipped < 8 * st_on.rays, "{mode:?}: {st_on:?}");
            }
        }
    }
}

/// The renderer samples what `Field::prepare` returns (a sampled volume's brick atlas):
/// every mode draws the same bits with it and without it, for a sparse and a dense
/// volume whose content crosses tile borders and touches the grid's faces, with 1 and 2
/// threads, and the counters agree.
#[test]
fn a_prepared_field_renders_the_same_bits() {
    let sparse = ball_in(DVec3::new(-3.0, 2.0, 0.5), 40, DVec3::new(16.0, 30.0, 33.0));
    let dense = sparse.to_dense().unwrap();
    let cam = Camera::look_at(
        DVec3::new(70.0, 45.0, -30.0),
        DVec3::new(16.0, 30.0, 30.0),
        DVec3::Y,
        Projection::Perspective { fov_y_deg: 40.0 },
    )
    .unwrap();
    let sparse_field = Sampled::new(&sparse, Filter::Trilinear);
    let dense_field = Sampled::new(&dense, Filter::Trilinear);
    assert!(sparse_field.prepare().is_some() && dense_field.prepare().is_some());
    let fields: [&dyn Field; 2] = [&sparse_field, &dense_field];
    for field in fields {
        for mode in modes() {
            let mut s = transparent(36, 30);
            s.sampling.packed_path = false; // the atlas path, not the packed one
            let (prepared, st_prepared) = go(field, &cam, &mode, &s);
            s.sampling.prepare_field = false;
            let (plain, st_plain) = go(field, &cam, &mode, &s);
            assert_eq!(bits(&prepared), bits(&plain), "{mode:?}");
            assert_eq!(st_prepared, st_plain, "{mode:?}");
            assert!(prepared.pixels.iter().any(|p| p.w > 0.0), "{mode:?}: empty image");
            let one_thread = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap()
                .install(|| {
                    let mut s = transparent(36, 30);
                    s.sampling.packed_path = false;
                    go(field, &cam, &mode, &s).0
                });
            assert_eq!(bits(&prepared), bits(&one_thread), "{mode:?}");
        }
    }
}

/// `k × k` supersampling is the box-filtered image of `k` times the resolution: each
/// pixel's sub-rays are the fine image's pixel-centre rays (up to the rounding of the
/// image-plane coordinates), so the images agree to 1e-4; `k = 1` is the plain image,
/// the ray count is `k²` per pixel, and 1 and 2 threads give the same bits.
#[test]
fn supersampling_is_a_box_filtered_finer_image() {
    let volume = ball(DVec3::ZERO);
    let field = Sampled::new(&volume, Filter::Trilinear);
    let cam = Camera::look_at(
        DVec3::new(30.0, 20.0, -25.0),
        DVec3::splat(11.5),
        DVec3::Y,
        Projection::Perspective { fov_y_deg: 35.0 },
    )
    .unwrap();
    let (w, h, k) = (18u32, 14u32, 3u32);
    // Unlit, so no colour exceeds 1 and is clamped before the fine image is averaged.
    let unlit = |w, h| RenderSettings {
        lighting: Lighting::unlit(),
        ..transparent(w, h)
    };
    for mode in modes() {
        let mut s = unlit(w, h);
        let (plain, _) = go(&field, &cam, &mode, &s);
        s.image.supersampling = 1;
        assert_eq!(bits(&go(&field, &cam, &mode, &s).0), bits(&plain));
        s.image.supersampling = k;
        let (ss, stats) = go(&field, &cam, &mode, &s);
        assert_eq!(stats.rays, (w * h * k * k) as u64);
        let (fine, _) = go(&field, &cam, &mode, &unlit(w * k, h * k));
        let mut differs = 0;
        for y in 0..h {
            for x in 0..w {
                let mut sum = Vec4::ZERO;
                for j in 0..k {
                    for i in 0..k {
                        // Straight RGBA over a transparent background: back to
                        // premultiplied before averaging.
                        let p = fine.get(x * k + i, y * k + j);
                        sum += (p.truncate() * p.w).extend(p.w);
                    }
                }
                let mean = sum / (k * k) as f32;
                let want = if mean.w > 0.0 {
                    (mean.truncate() / mean.w).extend(mean.w)
                } else {
                    Vec4::ZERO
                };
                let got = ss.get(x, y);
                assert!(
                    (got - want).abs().max_element() < 1e-4,
                    "{mode:?} ({x}, {y}): {got} vs {want}"
                );
                differs += (got != plain.get(x, y)) as u32;
            }
        }
        assert!(differs > 0, "{mode:?}: supersampling changed nothing");
        let one_thread = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| go(&field, &cam, &mode, &s).0);
        assert_eq!(bits(&ss), bits(&one_thread), "{mode:?}");
    }
    let mut s = transparent(w, h);
    s.image.supersampling = 0;
    assert!(render(&field, &cam, &modes()[0], &s, &NoProgress).is_err());
}
