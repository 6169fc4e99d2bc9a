//! Integration tests of the raycaster on an analytic sphere and on the same sphere
//! voxelized into a `SparseVolume` sampled trilinearly.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

use glam::{DVec3, IVec3, UVec3, Vec3, Vec4};
use volga_core::{Aabb, Field, FieldKind, Filter, Grid, NoProgress, Progress, Sampled, SparseVolume, Transform};
use volga_render::{
    first_hit, render, Camera, Image, ImageSettings, Integrator, Iso, Light, Lighting, Mip, Mode, Projection, Ray,
    RenderError, RenderSettings, RenderStats, Renderer, Sampling, SurfaceColour, TransferFunction, Volume, XRay,
};

// ---------------------------------------------------------------- test fields

const N: u32 = 48;
const RADIUS: f64 = 12.0;

fn centre() -> DVec3 {
    DVec3::splat((N as f64 - 1.0) / 2.0)
}

/// Ramp half-width `w = √3·h`: the density is linear in distance over every
/// trilinear cell touching the surface.
fn ramp_w(h: f64) -> f64 {
    3f64.sqrt() * h
}

fn sphere_density(p: DVec3, c: DVec3, r: f64, h: f64) -> f64 {
    (0.5 - ((p - c).length() - r) / (2.0 * ramp_w(h))).clamp(0.0, 1.0)
}

/// Analytic sphere: density 1 inside, 0 outside, a linear ramp of width 2w across
/// `|p − c| = r`, so the 0.5 iso-surface is exactly the sphere.
struct Sphere {
    c: DVec3,
    r: f64,
    h: f64,
    exact_gradient: bool,
}

impl Field for Sphere {
    fn bounds(&self) -> Aabb {
        let e = self.r + ramp_w(self.h) + self.h;
        Aabb::new(self.c - e, self.c + e)
    }
    fn value(&self, p: DVec3) -> f64 {
        sphere_density(p, self.c, self.r, self.h)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        if self.exact_gradient {
            let d = p - self.c;
            let dist = d.length();
            if dist > 0.0 && ((dist - self.r).abs() < ramp_w(self.h)) {
                -d / dist / (2.0 * ramp_w(self.h))
            } else {
                DVec3::ZERO
            }
        } else {
            let h = self.h;
            let v = |q: DVec3| self.value(q);
            DVec3::new(
                v(p + DVec3::X * h) - v(p - DVec3::X * h),
                v(p + DVec3::Y * h) - v(p - DVec3::Y * h),
                v(p + DVec3::Z * h) - v(p - DVec3::Z * h),
            ) / (2.0 * h)
        }
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.h)
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        let near = self.c.clamp(b.min, b.max);
        let far = DVec3::select((self.c - b.min).abs().cmpgt((self.c - b.max).abs()), b.min, b.max);
        let v = |q: DVec3| self.value(q);
        (v(far), v(near))
    }
}

fn analytic_sphere(exact_gradient: bool) -> Sphere {
    Sphere {
        c: centre(),
        r: RADIUS,
        h: 1.0,
        exact_gradient,
    }
}

/// The sphere's density at every voxel centre of a 48³ grid with spacing 1.
fn sphere_volume() -> &'static SparseVolume {
    static VOL: OnceLock<SparseVolume> = OnceLock::new();
    VOL.get_or_init(|| {
        let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::splat(N)).unwrap();
        let mut vol = SparseVolume::new(grid, 0.0, false);
        for ijk in grid.index_box().iter() {
            let p = grid.transform.voxel_center(ijk);
            vol.density.set(ijk, sphere_density(p, centre(), RADIUS, 1.0) as f32);
        }
        vol.density.prune();
        assert!(vol.density.brick_count() < 6 * 6 * 6, "outside bricks were pruned");
        vol
    })
}

fn sampled() -> Sampled<&'static SparseVolume> {
    Sampled::new(sphere_volume(), Filter::Trilinear)
}

/// Delegates to `inner`, counting `gradient` calls.
struct Counting<F> {
    inner: F,
    gradients: AtomicU64,
}

impl<F: Field> Field for Counting<F> {
    fn bounds(&self) -> Aabb {
        self.inner.bounds()
    }
    fn value(&self, p: DVec3) -> f64 {
        self.inner.value(p)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.gradients.fetch_add(1, Ordering::Relaxed);
        self.inner.gradient(p)
    }
    fn gradient_step(&self) -> DVec3 {
        self.inner.gradient_step()
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        self.inner.value_range(b)
    }
}

/// The sphere, but NaN everywhere in the half space x < centre.x (and NaN colour).
struct HalfNan(Sphere);

impl Field for HalfNan {
    fn bounds(&self) -> Aabb {
        self.0.bounds()
    }
    fn value(&self, p: DVec3) -> f64 {
        if p.x < self.0.c.x {
            f64::NAN
        } else {
            self.0.value(p)
        }
    }
    fn gradient_step(&self) -> DVec3 {
        self.0.gradient_step()
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        self.0.value_range(b)
    }
    fn has_colour(&self) -> bool {
        true
    }
    fn colour(&self, _: DVec3) -> Option<Vec3> {
        Some(Vec3::splat(f32::NAN))
    }
}

/// A homogeneous box of value 0.5 over [0, 10]³.
struct Slab;

impl Field for Slab {
    fn bounds(&self) -> Aabb {
        Aabb::new(DVec3::ZERO, DVec3::splat(10.0))
    }
    fn value(&self, _: DVec3) -> f64 {
        0.5
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::ONE
    }
    fn value_range(&self, _: &Aabb) -> (f64, f64) {
        (0.5, 0.5)
    }
}

// ---------------------------------------------------------------- helpers

fn ortho_camera(dir: DVec3, height_world: f64) -> Camera {
    let dir = dir.normalize();
    let up = if dir.cross(DVec3::Y).length() > 0.1 {
        DVec3::Y
    } else {
        DVec3::Z
    };
    Camera::look_at(
        centre() - dir * 60.0,
        centre(),
        up,
        Projection::Orthographic { height_world },
    )
    .unwrap()
}

fn iso_mode() -> Mode {
    Mode::Iso(Iso {
        value: 0.5,
        colour: SurfaceColour::Constant(Vec3::new(0.9, 0.7, 0.5)),
    })
}

fn volume_tf() -> TransferFunction {
    TransferFunction::new(vec![
        (0.0, Vec4::new(0.0, 0.0, 0.0, 0.0)),
        (0.05, Vec4::new(0.2, 0.3, 1.0, 0.0)),
        (0.5, Vec4::new(1.0, 0.6, 0.2, 0.15)),
        (1.0, Vec4::new(1.0, 1.0, 1.0, 0.4)),
    ])
    .unwrap()
}

fn volume_mode() -> Mode {
    Mode::Volume(Volume::new(volume_tf(), false))
}

fn settings(w: u32, h: u32) -> RenderSettings {
    RenderSettings {
        image: ImageSettings {
            width: w,
            height: h,
            tile_size: 8,
            ..Default::default()
        },
        lighting: Lighting {
            lights: vec![Light {
                direction: DVec3::new(-1.0, 0.5, -2.0),
                colour: Vec3::ONE,
            }],
            ..Default::default()
        },
        ..Default::default()
    }
}

fn bits(img: &Image) -> Vec<[u32; 4]> {
    img.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn max_diff(a: &Image, b: &Image) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (*p - *q).abs().max_element())
        .fold(0.0, f32::max)
}

fn assert_valid(img: &Image) {
    assert_eq!(img.pixels.len(), (img.width * img.height) as usize);
    for p in &img.pixels {
        assert!(
            p.is_finite() && p.cmpge(Vec4::ZERO).all() && p.cmple(Vec4::ONE).all(),
            "{p}"
        );
    }
}

fn go<F: Field>(field: &F, cam: &Camera, mode: &Mode, s: &RenderSettings) -> (Image, RenderStats) {
    render(field, cam, mode, s, &NoProgress).unwrap()
}

// ---------------------------------------------------------------- 1. first_hit accuracy

fn check_hit(field: &impl Field, ray: &Ray, tol: f64, must_hit: bool) -> bool {
    let hit = first_hit(field, ray, 0.5, 0.5);
    match hit {
        Some(h) => {
            let err = (h.world_pos - centre()).length() - RADIUS;
            assert!(
                err.abs() < tol,
                "hit {:?} off the sphere by {err} (ray {ray:?})",
                h.world_pos
            );
            assert!((ray.at(h.t) - h.world_pos).length() < 1e-9);
            true
        }
        None => {
            assert!(!must_hit, "ray {ray:?} should hit");
            false
        }
    }
}

/// Perpendicular distance of a ray's line from the sphere centre.
fn miss_distance(ray: &Ray) -> f64 {
    (centre() - ray.origin).cross(ray.dir).length() / ray.dir.length()
}

#[test]
fn first_hit_on_sampled_sphere_is_within_005_voxel() {
    let field = sampled();
    let mut hits = 0;
    let mut rays = 0;
    // Camera rays over the disk from several directions, one exactly axis-parallel.
    for dir in [
        -DVec3::Z,
        DVec3::X,
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(0.3, -1.0, 0.2),
    ] {
        let cam = ortho_camera(dir, 2.0 * RADIUS + 4.0);
        for py in 0..15 {
            for px in 0..15 {
                let ray = cam.ray(px as f64, py as f64, 15, 15);
                rays += 1;
                hits += check_hit(&field, &ray, 0.05, miss_distance(&ray) < RADIUS - 2.0) as usize;
            }
        }
    }
    // Axis-parallel rays exactly through voxel centres (x, y integers), along ±z.
    for y in (10..=37).step_by(3) {
        for x in 10..=37 {
            for dz in [1.0, -1.0] {
                let ray = Ray {
                    origin: DVec3::new(x as f64, y as f64, if dz > 0.0 { -10.0 } else { 60.0 }),
                    dir: DVec3::new(0.0, 0.0, dz),
                };
                rays += 1;
                hits += check_hit(&field, &ray, 0.05, miss_distance(&ray) < RADIUS - 2.0) as usize;
            }
        }
    }
    // Grazing rays near the silhouette, axis-parallel and oblique.
    for k in 0..60 {
        let a = k as f64 * 0.37;
        let off = RADIUS - 1.0 + 2.5 * (k as f64 / 59.0);
        for dir in [
            DVec3::X,
            DVec3::new(0.6, 0.0, 0.8),
            DVec3::new(1.0, 2.0, -0.5).normalize(),
        ] {
            let (u, v) = dir.any_orthonormal_pair();
            let offset = (u * a.cos() + v * a.sin()) * off;
            let ray = Ray {
                origin: centre() + offset - dir * 40.0,
                dir,
            };
            rays += 1;
            hits += check_hit(&field, &ray, 0.05, false) as usize;
        }
    }
    assert!(rays >= 500, "{rays}");
    assert!(hits > rays / 3, "{hits} of {rays}");
}

#[test]
fn first_hit_on_analytic_sphere_is_exact_and_handles_degenerate_rays() {
    let field = analytic_sphere(true);
    for k in 0..50 {
        let dir = DVec3::new((k as f64 * 0.7).sin(), (k as f64 * 1.3).cos(), 0.5).normalize();
        let ray = Ray {
            origin: centre() - dir * 50.0 + dir.any_orthogonal_vector() * (k as f64 * 0.2),
            dir,
        };
        check_hit(&field, &ray, 1e-6, true);
    }
    // Unnormalized direction: t in units of |dir|, same point.
    let ray = Ray {
        origin: centre() - DVec3::Z * 50.0,
        dir: DVec3::Z * 4.0,
    };
    let h = first_hit(&field, &ray, 0.5, 0.5).unwrap();
    assert!((h.world_pos.z - (centre().z - RADIUS)).abs() < 1e-6);
    // Degenerate inputs: no panic, no hit.
    let o = centre() - DVec3::Z * 50.0;
    assert!(first_hit(
        &field,
        &Ray {
            origin: o,
            dir: DVec3::ZERO
        },
        0.5,
        0.5
    )
    .is_none());
    assert!(first_hit(
        &field,
        &Ray {
            origin: o,
            dir: DVec3::Z
        },
        0.5,
        0.0
    )
    .is_none());
    assert!(first_hit(
        &field,
        &Ray {
            origin: o,
            dir: DVec3::Z
        },
        0.5,
        f64::NAN
    )
    .is_none());
    assert!(first_hit(
        &field,
        &Ray {
            origin: o,
            dir: -DVec3::Z
        },
        0.5,
        0.5
    )
    .is_none());
    assert!(first_hit(
        &field,
        &Ray {
            origin: o,
            dir: DVec3::Z
        },
        f64::NAN,
        0.5
    )
    .is_none());
    assert!(first_hit(
        &field,
        &Ray {
            origin: o,
            dir: DVec3::Z
        },
        0.5,
        1e-300
    )
    .is_some());
    // Starting inside the solid: the first crossing from below is none.
    let inside = Ray {
        origin: centre(),
        dir: DVec3::X,
    };
    assert!(first_hit(&field, &inside, 0.5, 0.5).is_none());
}

// ---------------------------------------------------------------- 2. determinism

#[test]
fn images_are_bit_identical_for_1_and_2_threads() {
    let field = sampled();
    let cam = Camera::look_at(
        centre() + DVec3::new(30.0, 20.0, 50.0),
        centre(),
        DVec3::Y,
        Projection::Perspective { fov_y_deg: 35.0 },
    )
    .unwrap();
    let s = settings(40, 36);
    for mode in [iso_mode(), volume_mode(), Mode::Mip(Mip), Mode::XRay(XRay)] {
        let run = |n: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
                .install(|| go(&field, &cam, &mode, &s))
        };
        let (a, sa) = run(1);
        let (b, sb) = run(2);
        assert_eq!(bits(&a), bits(&b), "{mode:?}");
        assert_eq!(sa, sb);
        assert_eq!(sa.rays, 40 * 36);
        assert_valid(&a);
    }
}

/// A prepared [`Renderer`] renders each view exactly as `render` does, however many
/// views it renders and in whatever order.
#[test]
fn a_prepared_renderer_renders_like_render() {
    let field = sampled();
    let cams: Vec<Camera> = [0.0f64, 2.0, 4.0]
        .iter()
        .map(|a| {
            let eye = centre() + DVec3::new(a.sin() * 60.0, 15.0, a.cos() * 60.0);
            Camera::look_at(eye, centre(), DVec3::Y, Projection::Perspective { fov_y_deg: 35.0 }).unwrap()
        })
        .collect();
    let s = settings(24, 20);
    let volume = Volume::new(volume_tf(), false);
    let prepared = Renderer::new(&field, &volume, &s).unwrap();
    for cam in cams.iter().rev().chain(&cams) {
        let (a, sa) = prepared.render(cam, &NoProgress);
        let (b, sb) = go(&field, cam, &volume_mode(), &s);
        assert_eq!(bits(&a), bits(&b));
        assert_eq!(sa, sb);
    }
    // Bad settings are refused when preparing.
    let mut bad = s.clone();
    bad.sampling.step_voxels = 0.0;
    assert!(Renderer::new(&field, &volume, &bad).is_err());
}

// ---------------------------------------------------------------- 3. gradients, early termination

#[test]
fn unlit_renders_never_evaluate_gradients() {
    let field = Counting {
        inner: sampled(),
        gradients: AtomicU64::new(0),
    };
    let cam = ortho_camera(DVec3::new(0.2, -0.3, 1.0), 30.0);
    let mut s = settings(24, 24);
    for mode in [iso_mode(), volume_mode(), Mode::Mip(Mip), Mode::XRay(XRay)] {
        s.lighting.lights.clear();
        let (_, stats) = go(&field, &cam, &mode, &s);
        assert_eq!(stats.gradient_evaluations, 0);
        assert_eq!(field.gradients.load(Ordering::Relaxed), 0);
        assert!(stats.samples > 0);
    }
    s.lighting.lights = settings(1, 1).lighting.lights;
    for mode in [iso_mode(), volume_mode()] {
        field.gradients.store(0, Ordering::Relaxed);
        let (_, stats) = go(&field, &cam, &mode, &s);
        assert!(stats.gradient_evaluations > 0);
        assert_eq!(field.gradients.load(Ordering::Relaxed), stats.gradient_evaluations);
    }
}

#[test]
fn early_termination_saves_samples_without_visible_change() {
    let field = sampled();
    let cam = ortho_camera(DVec3::new(0.1, 0.2, -1.0), 30.0);
    let opaque = Mode::Volume(Volume::new(
        TransferFunction::new(vec![
            (0.2, Vec4::new(0.0, 0.0, 0.0, 0.0)),
            (0.6, Vec4::new(1.0, 0.5, 0.2, 1.0)),
        ])
        .unwrap(),
        false,
    ));
    let mut s = settings(32, 32);
    let (on, st_on) = go(&field, &cam, &opaque, &s);
    s.sampling.early_termination_alpha = 1.01;
    let (off, st_off) = go(&field, &cam, &opaque, &s);
    assert!(st_on.rays_terminated_early > 0);
    assert_eq!(st_off.rays_terminated_early, 0);
    assert!(st_on.samples < st_off.samples, "{st_on:?} vs {st_off:?}");
    assert!(st_on.gradient_evaluations < st_off.gradient_evaluations);
    // What is cut off is at most (1 − 0.99) of the remaining light.
    let d = max_diff(&on, &off);
    assert!(d <= 0.01 + 1e-6, "{d}");
}

// ---------------------------------------------------------------- 4. empty-space skipping

#[test]
fn empty_space_skipping_never_changes_the_image() {
    let field = sampled();
    let cams = [
        ortho_camera(DVec3::new(0.3, 0.4, -1.0), 40.0),
        ortho_camera(DVec3::Z, 50.0),
        Camera::look_at(
            centre() + DVec3::new(-40.0, 25.0, 30.0),
            centre() + DVec3::new(2.0, 0.0, 0.0),
            DVec3::Y,
            Projection::Perspective { fov_y_deg: 50.0 },
        )
        .unwrap(),
    ];
    let coloured_iso = Mode::Iso(Iso {
        value: 0.3,
        colour: SurfaceColour::FromField,
    });
    for cam in &cams {
        // A step longer than the cells' one-spacing margin exercises iso brackets
        // that end in a skipped cell.
        for (mode, step_voxels) in [
            (volume_mode(), 0.5),
            (iso_mode(), 0.5),
            (iso_mode(), 8.0),
            (coloured_iso.clone(), 0.5),
            (Mode::Mip(Mip), 0.5),
        ] {
            let mut s = settings(32, 30);
            s.sampling.step_voxels = step_voxels;
            let (on, st_on) = go(&field, cam, &mode, &s);
            s.sampling.empty_space_skipping = false;
            let (off, st_off) = go(&field, cam, &mode, &s);
            assert_eq!(bits(&on), bits(&off), "{mode:?}");
            assert!(st_on.cells_skipped > 0, "{mode:?}");
            assert_eq!(st_off.cells_skipped, 0);
            // The packed iso path's outside-cell mask already spares the reads of
            // skipped cells: skipping saves walk steps there, not reads.
            let fewer =
                st_on.samples < st_off.samples || (matches!(mode, Mode::Iso(_)) && st_on.samples <= st_off.samples);
            assert!(fewer, "{mode:?}: {st_on:?} vs {st_off:?}");
            assert_eq!(st_on.rays_terminated_early, st_off.rays_terminated_early);
        }
    }
    // X-ray needs every sample: no skipping.
    let (_, st) = go(&field, &cams[0], &Mode::XRay(XRay), &settings(8, 8));
    assert_eq!(st.cells_skipped, 0);
}

#[test]
fn iso_render_matches_first_hit() {
    let field = sampled();
    let cam = ortho_camera(DVec3::new(0.5, -0.2, 1.0), 30.0);
    let mut s = settings(20, 20);
    s.lighting.lights.clear();
    s.image.background = Vec4::new(0.0, 0.0, 0.0, 0.0);
    let c = Vec3::new(0.9, 0.7, 0.5);
    let (img, _) = go(&field, &cam, &iso_mode(), &s);
    for y in 0..20 {
        for x in 0..20 {
            let hit = first_hit(&field, &cam.ray(x as f64, y as f64, 20, 20), 0.5, 0.5);
            let want = if hit.is_some() { c.extend(1.0) } else { Vec4::ZERO };
            assert_eq!(img.get(x, y), want, "pixel ({x}, {y})");
        }
    }
}

// ---------------------------------------------------------------- 5. opacity correction

#[test]
fn opacity_correction_makes_alpha_independent_of_step() {
    let cam = Camera::look_at(
        DVec3::new(5.0, 5.0, 20.0),
        DVec3::new(5.0, 5.0, 5.0),
        DVec3::Y,
        Projection::Orthographic { height_world: 4.0 },
    )
    .unwrap();
    let mode = Mode::Volume(Volume::new(
        TransferFunction::new(vec![(0.5, Vec4::new(1.0, 1.0, 1.0, 0.1))]).unwrap(),
        false,
    ));
    let alpha = |step: f64, reference: f64| {
        let s = RenderSettings {
            image: ImageSettings {
                width: 4,
                height: 4,
                background: Vec4::ZERO,
                ..Default::default()
            },
            sampling: Sampling {
                step_voxels: step,
                reference_step_voxels: reference,
                early_termination_alpha: 2.0,
                ..Default::default()
            },
            lighting: Lighting::unlit(),
        };
        let (img, stats) = go(&Slab, &cam, &mode, &s);
        assert_eq!(stats.samples, 16 * (10.0 / step).round() as u64);
        let a = img.pixels[5].w;
        assert!(img.pixels.iter().all(|p| p.w == a));
        a
    };
    let exact = 1.0 - 0.9f32.powi(10);
    let (a_half, a_quarter) = (alpha(0.5, 1.0), alpha(0.25, 1.0));
    assert!((a_half - a_quarter).abs() < 1e-3, "{a_half} vs {a_quarter}");
    assert!((a_half - exact).abs() < 1e-3, "{a_half} vs {exact}");
    // Without correction (reference = step) the result depends on the step.
    let (u_half, u_quarter) = (alpha(0.5, 0.5), alpha(0.25, 0.25));
    assert!((u_half - u_quarter).abs() > 0.05, "{u_half} vs {u_quarter}");
}

// ---------------------------------------------------------------- 6. shading

#[test]
fn lit_sphere_is_brightest_where_it_faces_the_light() {
    let cam = ortho_camera(-DVec3::Z, 2.0 * RADIUS + 6.0);
    let s = RenderSettings {
        image: ImageSettings {
            width: 33,
            height: 33,
            background: Vec4::new(0.0, 0.0, 0.0, 1.0),
            ..Default::default()
        },
        sampling: Sampling::default(),
        lighting: Lighting {
            lights: vec![Light::headlight(&cam)],
            ..Default::default()
        },
    };
    let lum = |p: Vec4| p.x + p.y + p.z;
    for exact in [true, false] {
        let field = analytic_sphere(exact);
        let (img, _) = go(&field, &cam, &iso_mode(), &s);
        let centre_px = img.get(16, 16);
        // The outermost pixel of the middle row that still hits the sphere.
        let edge_x = (0..33)
            .rev()
            .find(|&x| first_hit(&field, &cam.ray(x as f64, 16.0, 33, 33), 0.5, 0.5).is_some())
            .unwrap();
        assert!(edge_x > 16 && edge_x < 32);
        let edge = img.get(edge_x, 16);
        assert!(lum(centre_px) > lum(edge) + 0.3, "{centre_px} vs {edge}");
        assert!(lum(edge) > 0.0);
        assert_valid(&img);
    }
    // Volume mode shading also darkens the rim.
    let field = sampled();
    let (img, st) = go(&field, &cam, &volume_mode(), &s);
    assert!(st.gradient_evaluations > 0);
    assert!(lum(img.get(16, 16)) > lum(img.get(27, 16)));
}

// ---------------------------------------------------------------- 7. robustness

#[test]
fn axis_aligned_rays_through_voxel_centres_and_bounds_faces_are_finite() {
    let field = sampled();
    // Image x/y land exactly on integers (voxel centres); with 50 px / 50 units the
    // outermost rays run exactly along the bounds faces x, y ∈ {−1, 48}.
    for (px, height) in [(48, 48.0), (50, 50.0)] {
        let cam = Camera::look_at(
            DVec3::new(23.5, 23.5, -30.0),
            DVec3::new(23.5, 23.5, 0.0),
            DVec3::Y,
            Projection::Orthographic { height_world: height },
        )
        .unwrap();
        let r = cam.ray(0.0, 0.0, px, px);
        assert_eq!(r.dir, DVec3::Z);
        assert_eq!(r.origin.x.fract(), 0.0);
        assert_eq!(r.origin.y.fract(), 0.0);
        for mode in [iso_mode(), volume_mode(), Mode::Mip(Mip), Mode::XRay(XRay)] {
            for skip in [true, false] {
                let mut s = settings(px, px);
                s.sampling.empty_space_skipping = skip;
                let (img, _) = go(&field, &cam, &mode, &s);
                assert_valid(&img);
                assert_ne!(img.get(px / 2, px / 2), s.image.background, "{mode:?}");
            }
        }
    }
}

#[test]
fn nan_values_and_colours_do_not_produce_nan_pixels() {
    let field = HalfNan(analytic_sphere(false));
    let cam = ortho_camera(DVec3::new(0.2, 0.1, -1.0), 30.0);
    let modes = [
        iso_mode(),
        Mode::Iso(Iso {
            value: 0.5,
            colour: SurfaceColour::FromField,
        }),
        volume_mode(),
        Mode::Volume(Volume::new(volume_tf(), true)),
        Mode::Mip(Mip),
        Mode::XRay(XRay),
    ];
    for mode in modes {
        for skip in [true, false] {
            let mut s = settings(20, 20);
            s.sampling.empty_space_skipping = skip;
            s.image.background = Vec4::new(0.1, 0.2, 0.3, 0.5);
            let (img, _) = go(&field, &cam, &mode, &s);
            assert_valid(&img);
        }
    }
}

#[test]
fn progress_counts_tiles() {
    #[derive(Default)]
    struct Count {
        total: AtomicU64,
        done: AtomicU64,
        finished: AtomicU64,
    }
    impl Progress for Count {
        fn start(&self, stage: &str, total: u64) {
            assert_eq!(stage, "render");
            self.total.store(total, Ordering::Relaxed);
        }
        fn inc(&self, n: u64) {
            self.done.fetch_add(n, Ordering::Relaxed);
        }
        fn finish(&self) {
            self.finished.fetch_add(1, Ordering::Relaxed);
        }
    }
    let p = Count::default();
    let cam = ortho_camera(DVec3::Z, 30.0);
    let s = settings(21, 9); // 3 × 2 tiles of 8
    render(&analytic_sphere(true), &cam, &Mode::Mip(Mip), &s, &p).unwrap();
    assert_eq!(p.total.load(Ordering::Relaxed), 6);
    assert_eq!(p.done.load(Ordering::Relaxed), 6);
    assert_eq!(p.finished.load(Ordering::Relaxed), 1);
}

#[test]
fn invalid_settings_and_fields_are_errors() {
    let field = analytic_sphere(true);
    let cam = ortho_camera(DVec3::Z, 30.0);
    let ok = settings(4, 4);
    let with = |name: &'static str, edit: &dyn Fn(&mut RenderSettings)| {
        let mut s = ok.clone();
        edit(&mut s);
        (name, s)
    };
    let cases: Vec<(&str, RenderSettings)> = vec![
        with("image.width", &|s| s.image.width = 0),
        with("sampling.step_voxels", &|s| s.sampling.step_voxels = 0.0),
        with("sampling.step_voxels", &|s| s.sampling.step_voxels = 1e-12),
        with("sampling.reference_step_voxels", &|s| {
            s.sampling.reference_step_voxels = f64::NAN
        }),
        with("sampling.early_termination_alpha", &|s| {
            s.sampling.early_termination_alpha = f32::NAN
        }),
        with("image.background", &|s| s.image.background = Vec4::splat(2.0)),
        with("image.tile_size", &|s| s.image.tile_size = 0),
        with("lighting.lights[1].direction", &|s| {
            s.lighting.lights.push(Light {
                direction: DVec3::ZERO,
                colour: Vec3::ONE,
            })
        }),
        with("lighting.lights[0].colour", &|s| {
            s.lighting.lights[0].colour = Vec3::splat(f32::NAN)
        }),
        with("lighting.ambient_colour", &|s| s.lighting.ambient_colour = -Vec3::ONE),
        with("lighting.material.shininess", &|s| {
            s.lighting.material.shininess = f32::INFINITY
        }),
    ];
    for (name, s) in cases {
        let e = render(&field, &cam, &Mode::Mip(Mip), &s, &NoProgress).unwrap_err();
        assert!(e.to_string().contains(&format!("`{name}`")), "{name}: {e}");
        // The same check runs without a field (what a scene calls at validation), except
        // the field-dependent sample budget, which `Sampling::world_step` checks.
        let step = s.sampling.world_step(&field.bounds(), field.sample_spacing());
        let e2 = s.validate().and(step.map(|_| ())).unwrap_err();
        assert_eq!(e2, e, "{name}");
    }
    // Mode parameters are named `mode.<parameter>`.
    for (name, bad) in [
        (
            "mode.value",
            Iso {
                value: f64::INFINITY,
                colour: SurfaceColour::FromField,
            },
        ),
        (
            "mode.colour",
            Iso {
                value: 0.5,
                colour: SurfaceColour::Constant(Vec3::new(0.0, -1.0, 0.0)),
            },
        ),
    ] {
        let e = render(&field, &cam, &Mode::Iso(bad), &ok, &NoProgress).unwrap_err();
        assert!(e.to_string().contains(&format!("`{name}`")), "{name}: {e}");
    }
    let nan_iso = Mode::Iso(Iso {
        value: f64::NAN,
        colour: SurfaceColour::FromField,
    });
    assert!(render(&field, &cam, &nan_iso, &ok, &NoProgress).is_err());

    struct Unbounded;
    impl Field for Unbounded {
        fn bounds(&self) -> Aabb {
            Aabb::new(DVec3::splat(f64::NEG_INFINITY), DVec3::splat(f64::INFINITY))
        }
        fn value(&self, _: DVec3) -> f64 {
            1.0
        }
        fn gradient_step(&self) -> DVec3 {
            DVec3::ONE
        }
        fn value_range(&self, _: &Aabb) -> (f64, f64) {
            (1.0, 1.0)
        }
    }
    assert!(matches!(
        render(&Unbounded, &cam, &Mode::Mip(Mip), &ok, &NoProgress),
        Err(RenderError::BadFieldBounds { .. })
    ));
    assert!(first_hit(&Unbounded, &cam.ray(0.0, 0.0, 1, 1), 0.5, 0.5).is_none());
}

#[test]
fn rgba8_conversion() {
    let img = Image {
        width: 2,
        height: 1,
        pixels: vec![Vec4::new(0.0, 1.0, 0.5, 1.0), Vec4::new(f32::NAN, 2.0, -1.0, 0.5)],
    };
    let b = img.to_rgba8();
    assert_eq!(b.len(), 8);
    assert_eq!(&b[..4], &[0, 255, 186, 255]);
    assert_eq!(&b[4..], &[0, 255, 0, 128]);
    let _ = IVec3::ZERO;
}

// ---------------------------------------------------------------- 8. field kinds

/// The same sphere as a signed distance `|p − c| − r` (negative inside, world
/// units), normals from the default central differences with step `h`.
struct SdfSphere(Sphere);

impl Field for SdfSphere {
    fn kind(&self) -> FieldKind {
        FieldKind::SignedDistance
    }
    fn bounds(&self) -> Aabb {
        self.0.bounds()
    }
    fn background(&self) -> f64 {
        f64::INFINITY
    }
    fn value(&self, p: DVec3) -> f64 {
        (p - self.0.c).length() - self.0.r
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.0.h)
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        let c = self.0.c;
        let near = c.clamp(b.min, b.max);
        let far = DVec3::select((c - b.min).abs().cmpgt((c - b.max).abs()), b.min, b.max);
        ((near - c).length() - self.0.r, (far - c).length() - self.0.r)
    }
}

/// An SDF rendered iso at 0 and the density `clamp(½ − d/2w)` rendered iso at 0.5
/// show the same surface. Tolerances: both fields are analytic with the same zero
/// set and the same sign on each side of it (`½ − d/2w ≥ ½ ⟺ d ≤ 0`, up to one
/// rounding of `d/2w`), so they bracket the same crossings on the same lattice and
/// bisect to 1e-9 voxel: hits agree to 1e-6. Their central-difference gradients
/// are exactly proportional (factor −1/2w) while the stencil (±h = 1) stays in the
/// density ramp (w = √3), so normals, and shading, agree to f32 rounding: 1e-5.
#[test]
fn signed_distance_iso_matches_density_iso() {
    let density = analytic_sphere(false);
    let sdf = SdfSphere(analytic_sphere(false));
    let iso = |value: f64| {
        Mode::Iso(Iso {
            value,
            colour: SurfaceColour::Constant(Vec3::new(0.9, 0.7, 0.5)),
        })
    };
    let mut hits = 0;
    for dir in [-DVec3::Z, DVec3::new(1.0, 1.0, 1.0), DVec3::new(0.3, -1.0, 0.2)] {
        let cam = ortho_camera(dir, 2.0 * RADIUS + 4.0);
        // Lit from the side and unlit, with a transparent background so alpha is the
        // silhouette.
        for lit in [true, false] {
            let mut s = settings(31, 29);
            s.image.background = Vec4::ZERO;
            if !lit {
                s.lighting.lights.clear();
            }
            let (a, sa) = go(&density, &cam, &iso(0.5), &s);
            let (b, sb) = go(&sdf, &cam, &iso(0.0), &s);
            let alpha = |img: &Image| img.pixels.iter().map(|p| p.w).collect::<Vec<_>>();
            assert_eq!(alpha(&a), alpha(&b), "silhouettes differ ({dir}, lit {lit})");
            assert!(max_diff(&a, &b) < 1e-5, "{} ({dir}, lit {lit})", max_diff(&a, &b));
            assert_eq!(sa.gradient_evaluations, sb.gradient_evaluations);
            assert!(alpha(&a).contains(&1.0) && alpha(&a).contains(&0.0));
        }
        for py in 0..29 {
            for px in 0..31 {
                let ray = cam.ray(px as f64, py as f64, 31, 29);
                let (hd, hs) = (first_hit(&density, &ray, 0.5, 0.5), first_hit(&sdf, &ray, 0.0, 0.5));
                assert_eq!(hd.is_some(), hs.is_some(), "{ray:?}");
                if let (Some(hd), Some(hs)) = (hd, hs) {
                    hits += 1;
                    assert!((hd.world_pos - hs.world_pos).length() < 1e-6, "{hd:?} vs {hs:?}");
                    assert!(((hs.world_pos - centre()).length() - RADIUS).abs() < 1e-6);
                    // The outward normals the renderer shades with (`FieldKind::outward`
                    // of the gradient) point away from the centre for both kinds (central
                    // differences with h = 1 at r = 12 bend them by O(h²/r²)), and agree.
                    let radial = (hs.world_pos - centre()).normalize();
                    let nd = density.kind().outward(density.gradient(hd.world_pos)).normalize();
                    let ns = sdf.kind().outward(sdf.gradient(hs.world_pos)).normalize();
                    assert!(nd.dot(radial) > 0.9999, "density: {nd} vs {radial}");
                    assert!(ns.dot(radial) > 0.9999, "sdf: {ns} vs {radial}");
                    assert!((nd - ns).length() < 1e-6, "{nd} vs {ns}");
                }
            }
        }
    }
    assert!(hits > 500, "{hits}");
    // A ray starting inside the SDF solid has no crossing into it.
    let inside = Ray {
        origin: centre(),
        dir: DVec3::X,
    };
    assert!(first_hit(&sdf, &inside, 0.0, 0.5).is_none());
    // Skipping never changes an SDF image.
    let cam = ortho_camera(DVec3::new(0.3, 0.4, -1.0), 40.0);
    let mut s = settings(24, 24);
    let (on, st_on) = go(&sdf, &cam, &iso(0.0), &s);
    // (The tight analytic bounds leave no cell off the surface: nothing is skipped here.)
    s.sampling.empty_space_skipping = false;
    let (off, st_off) = go(&sdf, &cam, &iso(0.0), &s);
    assert_eq!(bits(&on), bits(&off));
    assert_eq!(st_on.cells_skipped, 0);
    // Runs of samples end at macro-cell borders with the grid, so less is read past a
    // hit; never more.
    assert!(st_on.samples <= st_off.samples);
    // The flip itself: a cell of positive distances is outside, of densities above
    // the iso value inside.
    let iso0 = Iso {
        value: 0.0,
        colour: SurfaceColour::FromField,
    };
    let iso5 = Iso {
        value: 0.5,
        ..iso0.clone()
    };
    use volga_render::CellClass::{Active, Inside, Outside};
    assert_eq!(iso0.classify_cell(1.0, 5.0, FieldKind::SignedDistance), Outside);
    assert_eq!(iso0.classify_cell(-5.0, -1.0, FieldKind::SignedDistance), Inside);
    assert_eq!(iso0.classify_cell(-1.0, 1.0, FieldKind::SignedDistance), Active);
    assert_eq!(iso5.classify_cell(0.6, 0.9, FieldKind::Density), Inside);
    assert_eq!(iso5.classify_cell(0.0, 0.4, FieldKind::Density), Outside);
    assert_eq!(iso5.classify_cell(0.0, 0.4, FieldKind::Binary), Outside);
}

// ---------------------------------------------------------------- 9. declared effects

/// What each mode declares matches what it does: gradients are evaluated exactly
/// when declared, colour is read exactly when declared, skipping happens only when
/// declared.
#[test]
fn declared_effects_match_the_render() {
    /// Counts colour reads.
    struct Coloured {
        inner: Counting<Sampled<&'static SparseVolume>>,
        colours: AtomicU64,
    }
    impl Field for Coloured {
        fn bounds(&self) -> Aabb {
            self.inner.bounds()
        }
        fn value(&self, p: DVec3) -> f64 {
            self.inner.value(p)
        }
        fn gradient(&self, p: DVec3) -> DVec3 {
            self.inner.gradient(p)
        }
        fn gradient_step(&self) -> DVec3 {
            self.inner.gradient_step()
        }
        fn value_range(&self, b: &Aabb) -> (f64, f64) {
            self.inner.value_range(b)
        }
        fn has_colour(&self) -> bool {
            true
        }
        fn colour(&self, _: DVec3) -> Option<Vec3> {
            self.colours.fetch_add(1, Ordering::Relaxed);
            Some(Vec3::new(0.2, 0.4, 0.6))
        }
    }
    let field = Coloured {
        inner: Counting {
            inner: sampled(),
            gradients: AtomicU64::new(0),
        },
        colours: AtomicU64::new(0),
    };
    let cam = ortho_camera(DVec3::new(0.2, -0.3, 1.0), 30.0);
    let modes = [
        iso_mode(),
        Mode::Iso(Iso {
            value: 0.5,
            colour: SurfaceColour::FromField,
        }),
        volume_mode(),
        Mode::Volume(Volume::new(volume_tf(), true)),
        Mode::Mip(Mip),
        Mode::XRay(XRay),
    ];
    let mut seen = [[false; 2]; 3];
    for mode in &modes {
        for lit in [true, false] {
            for skip in [true, false] {
                let mut s = settings(16, 16);
                s.sampling.empty_space_skipping = skip;
                if !lit {
                    s.lighting = Lighting::unlit();
                }
                let e = mode.integrator().effects(&s);
                assert!(!e.shadows.enabled);
                field.colours.store(0, Ordering::Relaxed);
                let (_, st) = go(&field, &cam, mode, &s);
                let colours = field.colours.load(Ordering::Relaxed);
                assert_eq!(e.gradients.enabled, st.gradient_evaluations > 0, "{mode:?} lit {lit}");
                assert_eq!(e.colour.enabled, colours > 0, "{mode:?}");
                assert_eq!(
                    e.empty_space_skipping.enabled,
                    st.cells_skipped > 0,
                    "{mode:?} skip {skip}"
                );
                if e.early_ray_termination.enabled {
                    assert!(st.rays_terminated_early > 0 || st.samples > 0);
                } else {
                    assert_eq!(st.rays_terminated_early, 0, "{mode:?}");
                }
                for (k, on) in [e.gradients.enabled, e.colour.enabled, e.empty_space_skipping.enabled]
                    .into_iter()
                    .enumerate()
                {
                    seen[k][on as usize] = true;
                }
            }
        }
    }
    assert_eq!(seen, [[true; 2]; 3], "every effect is seen both on and off");
    // Early ray termination is declared off when disabled in the settings.
    let mut s = settings(4, 4);
    assert!(volume_mode().integrator().effects(&s).early_ray_termination.enabled);
    s.sampling.early_termination_alpha = 1.5;
    assert!(!volume_mode().integrator().effects(&s).early_ray_termination.enabled);
}

/// An analytic ball as a density (a smooth, non-linear profile `1/(1 + e^{d/w})`, ½ on
/// the sphere) or as a signed distance (`|p − c| − r`, negative inside).
struct AnalyticBall {
    kind: FieldKind,
    c: DVec3,
    r: f64,
    voxel: f64,
}

impl Field for AnalyticBall {
    fn kind(&self) -> FieldKind {
        self.kind
    }
    fn bounds(&self) -> Aabb {
        Aabb::new(self.c - 2.0 * self.r, self.c + 2.0 * self.r)
    }
    fn background(&self) -> f64 {
        match self.kind {
            FieldKind::SignedDistance => 3.0 * self.r,
            _ => 0.0,
        }
    }
    fn value(&self, p: DVec3) -> f64 {
        let d = (p - self.c).length() - self.r;
        match self.kind {
            FieldKind::SignedDistance => d,
            _ => 1.0 / (1.0 + (d / (1.5 * self.voxel)).exp()),
        }
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.voxel)
    }
    fn value_range(&self, _: &Aabb) -> (f64, f64) {
        (f64::NEG_INFINITY, f64::INFINITY)
    }
}

/// Iso hits of an analytic sphere after refinement lie within 10⁻³ voxel of the exact
/// ray–sphere intersection, for a density and for a signed distance, near the origin and
/// at 10⁶, along oblique, axis-parallel and nearly grazing rays.
#[test]
fn iso_hits_of_an_analytic_sphere_are_within_a_thousandth_of_a_voxel() {
    for (kind, iso) in [(FieldKind::Density, 0.5), (FieldKind::SignedDistance, 0.0)] {
        for origin in [DVec3::new(0.3, -1.2, 2.5), DVec3::splat(1e6)] {
            let ball = AnalyticBall {
                kind,
                c: origin,
                r: 10.0,
                voxel: 0.5,
            };
            let mut hits = 0;
            for k in 0..200 {
                let dir = if k % 50 == 0 {
                    DVec3::X
                } else {
                    DVec3::new(
                        (k as f64 * 0.7).sin(),
                        (k as f64 * 1.3).cos(),
                        0.4 + (k as f64 * 0.37).sin(),
                    )
                    .normalize()
                };
                // Offsets across the disk, up to 0.999 r (grazing).
                let offset = dir.any_orthogonal_vector().normalize() * (ball.r * 0.999 * ((k % 20) as f64 / 19.0));
                let ray = volga_render::Ray {
                    origin: ball.c - dir * 30.0 + offset,
                    dir,
                };
                let hit = first_hit(&ball, &ray, iso, 0.5 * ball.voxel).expect("the ray crosses the sphere");
                // Exact entry: t = b − √(b² − (|o − c|² − r²)) with b = −(o − c)·dir.
                let oc = ray.origin - ball.c;
                let b = -oc.dot(dir);
                let t_exact = b - (b * b - (oc.length_squared() - ball.r * ball.r)).sqrt();
                let err_voxels = (hit.t - t_exact).abs() / ball.voxel;
                assert!(
                    err_voxels < 1e-3,
                    "{kind:?} at {origin}: ray {k} off by {err_voxels} voxel"
                );
                hits += 1;
            }
            assert_eq!(hits, 200);
        }
    }
}
