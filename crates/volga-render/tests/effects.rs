//! The effects a scene asks for: point lights, volumetric shadows (survey eq. 10) and
//! pre-integrated transfer functions — what they cost when off (nothing), what they
//! compute against brute force, and that they keep images deterministic and
//! independent of empty-space skipping.

use glam::{DVec3, Vec3, Vec4};
use volga_core::{Aabb, Field, NoProgress};
use volga_render::{
    render, Attenuation, Camera, Image, Iso, Light, LightId, Lighting, Mode, PointLight, Projection, RenderSettings,
    RenderStats, SurfaceColour, TransferFunction, Volume,
};

/// A ball of radius 1 (density 1 inside, a linear ramp 0.2 wide across the surface)
/// resting above a floor slab `y ∈ [−1.6, −1.3]`, in the box ±2, sampled every 0.05.
struct BallAndFloor;

impl Field for BallAndFloor {
    fn bounds(&self) -> Aabb {
        Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0))
    }
    fn value(&self, p: DVec3) -> f64 {
        let ball = (0.5 - (p.length() - 1.0) / 0.2).clamp(0.0, 1.0);
        let floor = (0.5 - ((p.y + 1.45).abs() - 0.15) / 0.2).clamp(0.0, 1.0);
        ball.max(floor)
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(0.05)
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        // Conservative from the distance to the ball and the floor (1-Lipschitz / 0.2).
        let near = b.min.max(DVec3::ZERO.min(b.max)).length();
        let far = b.min.abs().max(b.max.abs()).length();
        let ball = (
            (0.5 - (far - 1.0) / 0.2).clamp(0.0, 1.0),
            (0.5 - (near - 1.0) / 0.2).clamp(0.0, 1.0),
        );
        let dy_near = if b.min.y <= -1.45 && b.max.y >= -1.45 {
            0.0
        } else {
            (b.min.y + 1.45).abs().min((b.max.y + 1.45).abs())
        };
        let dy_far = (b.min.y + 1.45).abs().max((b.max.y + 1.45).abs());
        let floor = (
            (0.5 - (dy_far - 0.15) / 0.2).clamp(0.0, 1.0),
            (0.5 - (dy_near - 0.15) / 0.2).clamp(0.0, 1.0),
        );
        (ball.0.max(floor.0), ball.1.max(floor.1))
    }
}

fn camera() -> Camera {
    Camera::look_at(
        DVec3::new(0.5, 2.5, 6.0),
        DVec3::new(0.0, -0.5, 0.0),
        DVec3::Y,
        Projection::Perspective { fov_y_deg: 40.0 },
    )
    .unwrap()
}

fn iso() -> Mode {
    Mode::Iso(Iso {
        value: 0.5,
        colour: SurfaceColour::Constant(Vec3::new(0.9, 0.9, 0.9)),
    })
}

fn volume() -> Mode {
    let tf = TransferFunction::new(vec![
        (0.0, Vec4::ZERO),
        (0.3, Vec4::new(0.9, 0.8, 0.7, 0.0)),
        (0.6, Vec4::new(0.9, 0.8, 0.7, 0.3)),
        (1.0, Vec4::new(0.9, 0.8, 0.7, 0.5)),
    ])
    .unwrap();
    Mode::Volume(Volume::new(tf, false))
}

/// A light from above (directional 0), a dim one from the side (directional 1) and a
/// red point light (point 0), none casting shadows.
fn lit(w: u32) -> RenderSettings {
    let mut s = RenderSettings::new(w, w);
    s.lighting = Lighting {
        lights: vec![
            Light {
                direction: DVec3::new(0.3, 1.0, 0.2),
                colour: Vec3::ONE,
            },
            Light {
                direction: DVec3::new(-1.0, 0.2, 0.3),
                colour: Vec3::splat(0.3),
            },
        ],
        point_lights: vec![PointLight::new(DVec3::new(1.8, 0.5, 1.5), Vec3::new(1.0, 0.2, 0.1))],
        ..Lighting::default()
    };
    s
}

fn go(mode: &Mode, s: &RenderSettings) -> (Image, RenderStats) {
    render(&BallAndFloor, &camera(), mode, s, &NoProgress).unwrap()
}

fn bits(img: &Image) -> Vec<[u32; 4]> {
    img.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn lum(p: Vec4) -> f32 {
    p.x + p.y + p.z
}

#[test]
fn shadows_cost_nothing_unless_a_light_asks_for_them() {
    for mode in [iso(), volume()] {
        // No light casts shadows: not one shadow ray or sample.
        let s = lit(24);
        let (plain, stats) = go(&mode, &s);
        assert_eq!((stats.shadow_rays, stats.shadow_samples), (0, 0));
        // Light 0 casts them: rays and samples are spent on light 0 only — as many as
        // in an image where light 0 is the only light at all.
        let mut one = lit(24);
        one.lighting.shadows.casters = vec![LightId::Directional(0)];
        let (shadowed, with_others) = go(&mode, &one);
        assert!(with_others.shadow_rays > 0 && with_others.shadow_samples > 0);
        let mut alone = one.clone();
        alone.lighting.lights.truncate(1);
        alone.lighting.point_lights.clear();
        let (_, only) = go(&mode, &alone);
        assert_eq!(
            (with_others.shadow_rays, with_others.shadow_samples),
            (only.shadow_rays, only.shadow_samples)
        );
        // Shadows only darken, and they darken something (the floor under the ball).
        let darker = plain
            .pixels
            .iter()
            .zip(&shadowed.pixels)
            .filter(|(a, b)| lum(**b) < lum(**a) - 1e-3);
        assert!(darker.count() > 10);
        assert!(plain
            .pixels
            .iter()
            .zip(&shadowed.pixels)
            .all(|(a, b)| lum(*b) <= lum(*a) + 1e-5));
        // The shadow quality knob: a finer shadow step reads more samples.
        let mut fine = one.clone();
        fine.lighting.shadows.step_voxels = 0.25;
        let (_, fine_stats) = go(&mode, &fine);
        assert!(fine_stats.shadow_samples > 2 * with_others.shadow_samples);
    }
}

#[test]
fn the_light_space_pre_pass_replaces_shadow_rays_and_draws_close_to_them() {
    let mut s = lit(24);
    s.lighting.point_lights.clear();
    s.lighting.shadows.casters = vec![LightId::Directional(0)];
    let (rays, ray_stats) = go(&volume(), &s);
    s.lighting.shadows.light_space = true;
    let (grid, grid_stats) = go(&volume(), &s);
    assert!(ray_stats.shadow_rays > 0 && ray_stats.shadow_lookups == 0);
    assert_eq!((grid_stats.shadow_rays, grid_stats.shadow_samples), (0, 0));
    assert_eq!(grid_stats.shadow_lookups, ray_stats.shadow_rays);
    // The same shadows up to interpolation: mean channel difference below 2 %.
    let mean: f32 = rays
        .pixels
        .iter()
        .zip(&grid.pixels)
        .map(|(a, b)| (*a - *b).abs().truncate().element_sum() / 3.0)
        .sum::<f32>()
        / rays.pixels.len() as f32;
    assert!(mean < 0.02, "{mean}");
}

#[test]
fn point_lights_colour_and_attenuate() {
    let mut s = RenderSettings::new(32, 32);
    s.lighting = Lighting {
        lights: Vec::new(),
        point_lights: vec![
            PointLight::new(DVec3::new(3.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 0.0)),
            PointLight::new(DVec3::new(-3.0, 0.0, 1.0), Vec3::new(0.0, 0.0, 1.0)),
        ],
        ambient_colour: Vec3::ZERO,
        ..Lighting::default()
    };
    let cam = Camera::look_at(
        DVec3::new(0.0, 0.0, 6.0),
        DVec3::ZERO,
        DVec3::Y,
        Projection::Perspective { fov_y_deg: 30.0 },
    )
    .unwrap();
    let mode = Mode::Iso(Iso {
        value: 0.5,
        colour: SurfaceColour::Constant(Vec3::ONE),
    });
    let (img, stats) = render(&BallAndFloor, &cam, &mode, &s, &NoProgress).unwrap();
    assert!(stats.gradient_evaluations > 0);
    // The camera's image x grows towards world +x here (right = forward × up).
    let right = img.get(22, 16);
    let left = img.get(9, 16);
    assert!(right.x > 0.3 && right.z < 0.05, "{right}");
    assert!(left.z > 0.3 && left.x < 0.05, "{left}");
    // Inverse-square attenuation: the same lights twice as far are about 4× dimmer
    // at the ball's centre line (the diffuse term only changes a little in direction).
    let mut far = s.clone();
    for p in &mut far.lighting.point_lights {
        p.attenuation = Attenuation::INVERSE_SQUARE;
    }
    let (near_img, _) = render(&BallAndFloor, &cam, &mode, &far, &NoProgress).unwrap();
    for p in &mut far.lighting.point_lights {
        p.position *= 2.0;
    }
    let (far_img, _) = render(&BallAndFloor, &cam, &mode, &far, &NoProgress).unwrap();
    let (n, f) = (near_img.get(22, 16).x, far_img.get(22, 16).x);
    assert!(f > 0.0 && n / f > 2.5 && n / f < 6.0, "{n} / {f}");
}

#[test]
fn effects_are_deterministic_and_independent_of_skipping() {
    let mut s = lit(20);
    s.lighting.shadows.casters = vec![LightId::Directional(0), LightId::Point(0)];
    s.sampling.step_voxels = 1.5;
    for mode in [iso(), volume()] {
        for (pre_integration, light_space) in [(false, false), (true, false), (true, true)] {
            let mut s = s.clone();
            s.sampling.pre_integration = pre_integration && matches!(mode, Mode::Volume(_));
            s.lighting.shadows.light_space = light_space;
            let run = |threads: usize, skipping: bool| {
                let mut s = s.clone();
                s.sampling.empty_space_skipping = skipping;
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| go(&mode, &s))
            };
            let (a, sa) = run(1, true);
            let (b, sb) = run(2, true);
            let (c, sc) = run(2, false);
            assert_eq!(bits(&a), bits(&b), "1 vs 2 threads");
            assert_eq!(sa, sb);
            assert_eq!(
                bits(&a),
                bits(&c),
                "skipping on vs off (pre-integration {pre_integration})"
            );
            assert!(sa.cells_skipped > 0 && sc.cells_skipped == 0);
            assert!(sa.shadow_rays > 0);
            // The light-space pre-pass serves the directional light of volume images.
            let volume_mode = matches!(mode, Mode::Volume(_));
            assert_eq!(sa.shadow_lookups > 0, light_space && volume_mode);
            assert!(a.pixels.iter().all(|p| p.is_finite()));
        }
    }
}

/// Density `(z + 1)/2` in the box ±1 (spacing 1/32): a ray along −z sees the values
/// fall linearly from 1 to 0, exactly the segments pre-integration assumes.
struct RampZ;

impl Field for RampZ {
    fn bounds(&self) -> Aabb {
        Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0))
    }
    fn value(&self, p: DVec3) -> f64 {
        (p.z + 1.0) / 2.0
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(1.0 / 32.0)
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        ((b.min.z + 1.0) / 2.0, (b.max.z + 1.0) / 2.0)
    }
}

#[test]
fn pre_integration_of_a_sharp_transfer_function_matches_fine_steps() {
    // A red peak 0.04 wide at 0.5, crossed by every ray.
    let tf = TransferFunction::new(vec![
        (0.0, Vec4::ZERO),
        (0.48, Vec4::new(1.0, 0.1, 0.0, 0.0)),
        (0.5, Vec4::new(1.0, 0.1, 0.0, 0.8)),
        (0.52, Vec4::new(1.0, 0.1, 0.0, 0.0)),
        (1.0, Vec4::ZERO),
    ])
    .unwrap();
    let mode = Mode::Volume(Volume::new(tf, false));
    let cam = Camera::look_at(
        DVec3::new(0.0, 0.0, 3.0),
        DVec3::ZERO,
        DVec3::Y,
        Projection::Orthographic { height_world: 1.0 },
    )
    .unwrap();
    let image = |step_voxels: f64, pre_integration: bool| {
        let mut s = RenderSettings::new(4, 4);
        s.lighting = Lighting::unlit();
        s.image.background = Vec4::new(0.0, 0.0, 0.0, 1.0);
        s.sampling.step_voxels = step_voxels;
        s.sampling.pre_integration = pre_integration;
        s.sampling.early_termination_alpha = 2.0;
        render(&RampZ, &cam, &mode, &s, &NoProgress).unwrap().0
    };
    // Brute force: post-classification at 1/64 voxel (the peak spans 82 samples).
    let reference = image(1.0 / 64.0, false).get(1, 1);
    assert!(reference.x > 0.3, "{reference}");
    // Tolerance 0.02 per channel: the table's bilinear interpolation and sub-steps.
    for step in [1.0, 2.0, 3.0, 5.0] {
        let pre = image(step, true).get(1, 1);
        assert!(
            (pre - reference).abs().max_element() < 0.02,
            "step {step}: pre-integrated {pre} vs {reference}"
        );
    }
    // Post-classification at large steps is off by far more (the slab artefact).
    let post = image(5.0, false).get(1, 1);
    assert!((post - reference).abs().max_element() > 0.1, "{post} vs {reference}");
}
