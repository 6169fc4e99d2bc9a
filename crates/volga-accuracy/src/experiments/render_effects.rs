//! The raycaster's accuracy knobs on a shadowed, semi-transparent volume rendering:
//! ray step × reconstruction filter × pre-integration × shadow ray step
//! ([`EXPERIMENT`]), and pixel supersampling ([`SUPERSAMPLING`]), each image's RMS
//! error against one reference: the analytic field rendered with a 1/8-voxel step,
//! 1/8-voxel shadow rays and 4 × 4 rays per pixel.
//!
//! The scene: three Gaussian blobs sampled on a 33³ grid over `[−1, 1]³`, classified
//! by a transfer function with a sharp opaque shell at ρ = ½ (0.04 wide: the case
//! pre-integration is for) and a faint haze at ρ ≈ 0.3, lit by one directional light
//! that casts volumetric shadows (survey eq. 10) and shaded (eq. 9). The blobs are
//! smooth on the grid, so the filters' own error is small beside the step's and the
//! shadows'.

use std::sync::Mutex;

use glam::{DVec3, UVec3, Vec3, Vec4};
use volga_core::{Aabb, DenseVolume, Field, Filter, Grid, NoProgress, Sampled, Transform};
use volga_render::{
    render, Camera, Image, Light, LightId, Lighting, Mode, Projection, RenderSettings, TransferFunction, Volume,
};

use super::render_step::image_rms;
use super::{Context, Experiment, Size};
use crate::{timed, KnobResult, Metric, Series, Setting};

pub const EXPERIMENT: Experiment = Experiment {
    id: "render_effects",
    run,
};

pub const SUPERSAMPLING: Experiment = Experiment {
    id: "render_supersampling",
    run: run_supersampling,
};

/// Voxels per axis of the sampled blobs, and their spacing on `[−1, 1]³`.
const DIMS: u32 = 33;
const SPACING: f64 = 2.0 / (DIMS - 1) as f64;

/// The reference's ray step and shadow step (voxels) and rays per pixel per axis.
const REFERENCE_STEP_VOXELS: f64 = 0.125;
const REFERENCE_SUPERSAMPLING: u32 = 4;

/// Three Gaussian blobs, `ρ(p) = Σ a_i·exp(−|p − c_i|²/(2σ_i²))`, seen in `[−1, 1]³`.
pub(crate) struct Blobs;

const BLOBS: [(DVec3, f64, f64); 3] = [
    (DVec3::new(-0.15, 0.3, 0.0), 0.32, 0.9),
    (DVec3::new(0.35, -0.35, 0.2), 0.25, 0.8),
    (DVec3::new(-0.3, -0.45, -0.35), 0.22, 0.75),
];

impl Blobs {
    fn density(p: DVec3) -> f64 {
        BLOBS
            .iter()
            .map(|&(c, s, a)| a * (-(p - c).length_squared() / (2.0 * s * s)).exp())
            .sum()
    }
}

impl Field for Blobs {
    fn bounds(&self) -> Aabb {
        Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0))
    }
    fn value(&self, p: DVec3) -> f64 {
        Blobs::density(p)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        BLOBS
            .iter()
            .map(|&(c, s, a)| {
                let d = p - c;
                d * (-a / (s * s) * (-d.length_squared() / (2.0 * s * s)).exp())
            })
            .sum()
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(SPACING)
    }
    /// Each blob is monotone in the distance to its centre: its range over a box is
    /// given by the nearest and farthest points.
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        BLOBS.iter().fold((0.0, 0.0), |(lo, hi), &(c, s, a)| {
            let near = (c.clamp(b.min, b.max) - c).length_squared();
            let far = (c - b.min).abs().max((c - b.max).abs()).length_squared();
            let g = |d2: f64| a * (-d2 / (2.0 * s * s)).exp();
            (lo + g(far), hi + g(near))
        })
    }
}

/// The blobs sampled at the voxel centres of the 33³ grid over `[−1, 1]³`.
fn blobs_volume() -> DenseVolume {
    let transform = Transform::new(DVec3::splat(-1.0), DVec3::splat(SPACING)).expect("valid transform");
    let grid = Grid::new(transform, UVec3::splat(DIMS)).expect("valid grid");
    let mut volume = DenseVolume::new(grid, 0.0, false).expect("small grid");
    for ijk in grid.index_box().iter() {
        volume
            .density
            .set(ijk, Blobs::density(transform.voxel_center(ijk)) as f32);
    }
    volume
}

/// The sampled volume seen only inside `[−1, 1]³`, like the analytic reference.
struct Clipped<F>(F);

impl<F: Field> Field for Clipped<F> {
    fn bounds(&self) -> Aabb {
        Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0))
    }
    fn background(&self) -> f64 {
        self.0.background()
    }
    fn value(&self, p: DVec3) -> f64 {
        self.0.value(p)
    }
    fn values_along(&self, line: &volga_core::Line, first: u64, out: &mut [f64]) {
        self.0.values_along(line, first, out)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.0.gradient(p)
    }
    fn gradients_at(&self, points: &[DVec3], out: &mut [DVec3]) {
        self.0.gradients_at(points, out)
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

pub(crate) fn transfer_function() -> TransferFunction {
    let haze = Vec3::new(0.35, 0.55, 0.95);
    let shell = Vec3::new(0.95, 0.6, 0.25);
    TransferFunction::new(vec![
        (0.0, Vec4::ZERO),
        (0.2, haze.extend(0.0)),
        (0.3, haze.extend(0.06)),
        (0.4, haze.extend(0.0)),
        (0.48, shell.extend(0.0)),
        (0.5, shell.extend(0.85)),
        (0.52, shell.extend(0.0)),
        (1.0, shell.extend(0.0)),
    ])
    .expect("valid transfer function")
}

fn camera() -> Camera {
    Camera::look_at(
        DVec3::new(2.2, 1.4, 2.6),
        DVec3::new(0.0, -0.1, 0.0),
        DVec3::Y,
        Projection::Perspective { fov_y_deg: 36.0 },
    )
    .expect("valid camera")
}

/// The image settings of every render: one white light from above casting shadows.
/// A shadow step in voxels: shadow rays, or the light-space pre-pass at that step.
#[derive(Clone, Copy)]
struct ShadowQuality(f64, bool);

fn settings(size: u32, step_voxels: f64, shadow_step_voxels: f64, pre_integration: bool, k: u32) -> RenderSettings {
    let mut s = RenderSettings::new(size, size);
    s.sampling.step_voxels = step_voxels;
    s.sampling.pre_integration = pre_integration;
    s.image.supersampling = k;
    s.lighting = Lighting {
        lights: vec![Light {
            direction: DVec3::new(0.4, 1.0, 0.3),
            colour: Vec3::ONE,
        }],
        ..Lighting::default()
    };
    s.lighting.shadows.casters = vec![LightId::Directional(0)];
    s.lighting.shadows.step_voxels = shadow_step_voxels;
    s
}

fn mode() -> Mode {
    Mode::Volume(Volume::new(transfer_function(), false))
}

fn image_size(size: Size) -> u32 {
    size.pick(12, 48)
}

/// The reference image at `size` pixels, computed once per run and size (both
/// experiments share it).
fn reference(size: u32) -> Image {
    static CACHE: Mutex<Option<(u32, Image)>> = Mutex::new(None);
    let mut cache = CACHE.lock().expect("reference cache");
    if let Some((s, image)) = cache.as_ref() {
        if *s == size {
            return image.clone();
        }
    }
    let s = settings(
        size,
        REFERENCE_STEP_VOXELS,
        REFERENCE_STEP_VOXELS,
        false,
        REFERENCE_SUPERSAMPLING,
    );
    let (image, _) = render(&Blobs, &camera(), &mode(), &s, &NoProgress).expect("valid reference render");
    *cache = Some((size, image.clone()));
    image
}

/// Renders the sampled blobs with `filter` under `s` (timed) and measures the image.
fn measure(
    volume: &DenseVolume,
    filter: Filter,
    s: &RenderSettings,
    reference: &Image,
    label: String,
    params: &[(&str, f64)],
) -> Setting {
    let field = Clipped(Sampled::new(volume, filter));
    let ((image, stats), timing) = timed(|| render(&field, &camera(), &mode(), s, &NoProgress).expect("valid render"));
    let memory = volume.payload_bytes() + image.pixels.len() as u64 * 16;
    Setting::new(label, params, timing, memory)
        .error("image_rms", image_rms(&image, reference))
        .error(
            "shadow_samples_per_ray",
            stats.shadow_samples as f64 / stats.rays.max(1) as f64,
        )
}

fn metrics() -> Vec<Metric> {
    vec![
        Metric {
            id: "image_rms",
            label: "image error, RMS (linear RGB, 0–1)",
        },
        Metric {
            id: "shadow_samples_per_ray",
            label: "shadow samples per view ray (work, not error)",
        },
    ]
}

const REFERENCE_TEXT: &str = "the analytic blobs (no reconstruction) rendered with a 1/8-voxel ray step, 1/8-voxel shadow rays and 4 × 4 rays per pixel, post-classified";

fn run(ctx: &Context) -> KnobResult {
    let size = image_size(ctx.size);
    let steps: &[f64] = ctx.size.pick(&[2.0, 0.5], &[2.0, 1.0, 0.5, 0.25]);
    let filters: &[(Filter, &str)] = ctx.size.pick(
        &[(Filter::Trilinear, "trilinear")],
        &[(Filter::Trilinear, "trilinear"), (Filter::CatmullRom, "Catmull–Rom")],
    );
    let shadow_steps: &[ShadowQuality] = ctx.size.pick(
        &[ShadowQuality(1.0, false), ShadowQuality(1.0, true)],
        &[
            ShadowQuality(2.0, false),
            ShadowQuality(1.0, false),
            ShadowQuality(0.5, false),
            ShadowQuality(1.0, true),
        ],
    );
    let runs = steps.len() * filters.len() * 2 * shadow_steps.len();
    ctx.start("render effects", runs + 1);
    let volume = blobs_volume();
    let reference = reference(size);
    ctx.setting_done();
    let mut series = Vec::new();
    for &(filter, filter_name) in filters {
        for pre_integration in [false, true] {
            for &ShadowQuality(shadow_step, light_space) in shadow_steps {
                let name = format!(
                    "{filter_name}, {}, {} {shadow_step}",
                    if pre_integration {
                        "pre-integrated"
                    } else {
                        "post-classified"
                    },
                    if light_space {
                        "light-space pre-pass, step"
                    } else {
                        "shadow rays, step"
                    }
                );
                let settings = steps
                    .iter()
                    .map(|&step| {
                        let mut s = settings(size, step, shadow_step, pre_integration, 1);
                        s.lighting.shadows.light_space = light_space;
                        let params = [
                            ("step_voxels", step),
                            ("shadow_step_voxels", shadow_step),
                            ("pre_integration", pre_integration as u8 as f64),
                            ("light_space", light_space as u8 as f64),
                        ];
                        let setting = measure(&volume, filter, &s, &reference, format!("Δs={step}"), &params);
                        ctx.setting_done();
                        setting
                    })
                    .collect();
                series.push(Series { name, settings });
            }
        }
    }
    ctx.finish();
    KnobResult {
        id: "render_effects",
        title: "Ray step × filter × pre-integration × shadow step (shadowed volume rendering)",
        knob: "ray step Δs in voxels (labels), reconstruction filter, pre-integrated or post-classified transfer function, and shadow quality (series): shadow rays at a step in voxels, or the light-space pre-pass (one transmittance grid per light at that step), for three Gaussian blobs sampled on 33³ voxels, a sharp opaque shell and a faint haze, one directional light casting volumetric shadows (eq. 10)",
        reference: REFERENCE_TEXT,
        timed: "render (volume mode with shadows, 48² pixels in the full run, table build and light-space pre-pass included), all threads",
        metrics: metrics(),
        series,
    }
}

fn run_supersampling(ctx: &Context) -> KnobResult {
    let size = image_size(ctx.size);
    let ks: &[u32] = ctx.size.pick(&[1, 2], &[1, 2, 3, 4]);
    ctx.start("render supersampling", 2 * ks.len() + 1);
    let volume = blobs_volume();
    let reference = reference(size);
    ctx.setting_done();
    let series = [false, true]
        .into_iter()
        .map(|pre_integration| Series {
            name: format!(
                "trilinear, Δs = 0.5, shadow step 1, {}",
                if pre_integration {
                    "pre-integrated"
                } else {
                    "post-classified"
                }
            ),
            settings: ks
                .iter()
                .map(|&k| {
                    let s = settings(size, 0.5, 1.0, pre_integration, k);
                    let params = [
                        ("supersampling", k as f64),
                        ("pre_integration", pre_integration as u8 as f64),
                    ];
                    let setting = measure(&volume, Filter::Trilinear, &s, &reference, format!("k={k}"), &params);
                    ctx.setting_done();
                    setting
                })
                .collect(),
        })
        .collect();
    ctx.finish();
    KnobResult {
        id: "render_supersampling",
        title: "Pixel supersampling k × k (shadowed volume rendering)",
        knob: "rays per pixel k × k (labels) at ray step 0.5 voxel, trilinear, shadow step 1 voxel, post-classified or pre-integrated, on the scene of render_effects",
        reference: REFERENCE_TEXT,
        timed: "render (volume mode with shadows, 48² pixels in the full run), all threads",
        metrics: metrics(),
        series,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The analytic gradient and value ranges the reference relies on, against
    /// central differences and brute-force sampling.
    #[test]
    fn blobs_gradient_and_ranges_are_right() {
        let h = 1e-5;
        for p in [DVec3::ZERO, DVec3::new(0.3, -0.2, 0.5), DVec3::new(-0.7, 0.1, -0.2)] {
            let fd = DVec3::new(
                Blobs::density(p + DVec3::X * h) - Blobs::density(p - DVec3::X * h),
                Blobs::density(p + DVec3::Y * h) - Blobs::density(p - DVec3::Y * h),
                Blobs::density(p + DVec3::Z * h) - Blobs::density(p - DVec3::Z * h),
            ) / (2.0 * h);
            assert!((Blobs.gradient(p) - fd).length() < 1e-6, "{p}");
        }
        let b = Aabb::new(DVec3::new(-0.5, -0.2, -0.1), DVec3::new(0.1, 0.4, 0.3));
        let (lo, hi) = Blobs.value_range(&b);
        for i in 0..=10 {
            for j in 0..=10 {
                for k in 0..=10 {
                    let t = DVec3::new(i as f64, j as f64, k as f64) / 10.0;
                    let v = Blobs::density(b.min + (b.max - b.min) * t);
                    assert!(v >= lo - 1e-12 && v <= hi + 1e-12, "{v} not in [{lo}, {hi}]");
                }
            }
        }
    }

    /// The reference is converged: halving its step again moves it far less than
    /// the coarsest setting's error.
    #[test]
    fn reference_is_converged_in_its_step() {
        let size = 8;
        let reference = reference(size);
        let mut s = settings(size, REFERENCE_STEP_VOXELS / 2.0, REFERENCE_STEP_VOXELS / 2.0, false, 4);
        s.image.supersampling = REFERENCE_SUPERSAMPLING;
        let (finer, _) = render(&Blobs, &camera(), &mode(), &s, &NoProgress).unwrap();
        let (coarse, _) = render(
            &Blobs,
            &camera(),
            &mode(),
            &settings(size, 2.0, 2.0, false, 4),
            &NoProgress,
        )
        .unwrap();
        let converged = image_rms(&reference, &finer);
        let coarse = image_rms(&reference, &coarse);
        assert!(converged * 5.0 < coarse, "{converged} vs {coarse}");
    }
}
