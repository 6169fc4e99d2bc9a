//! Render step and reconstruction filter on the Marschner–Lobb volume: image and
//! hit-position error against a supersampled small-step rendering of the analytic
//! signal.

use glam::{DVec3, UVec3, Vec3, Vec4};
use rayon::prelude::*;
use volga_core::{DenseVolume, Field, Filter, Grid, NoProgress, Sampled, Transform};
use volga_render::{first_hit, render, Camera, Image, Iso, Mode, Projection, RenderSettings, SurfaceColour};

use super::{Context, Experiment};
use crate::references::MarschnerLobb;
use crate::{timed, KnobResult, Metric, Series, Setting};

pub const EXPERIMENT: Experiment = Experiment { id: "render_step", run };

/// Steps of the reference (in voxels of the 41³ sampling) and its pixel supersampling.
pub(crate) const REFERENCE_STEP_VOXELS: f64 = 1.0 / 32.0;
const REFERENCE_SUPERSAMPLING: u32 = 2;

/// A field seen only inside the scene box `[−1, 1]³` (background outside): the
/// sampled volume's reconstruction reaches one voxel beyond its outer samples, where it
/// blends with the background; clipping it to the box the analytic signal is defined
/// on makes rays of both enter at the same point, so errors are the interior's.
pub(crate) struct Clipped<F>(pub F);

impl<F: Field> Field for Clipped<F> {
    fn bounds(&self) -> volga_core::Aabb {
        crate::references::scene_box()
    }
    fn kind(&self) -> volga_core::FieldKind {
        self.0.kind()
    }
    fn background(&self) -> f64 {
        self.0.background()
    }
    fn value(&self, world_pos: DVec3) -> f64 {
        self.0.value(world_pos)
    }
    fn gradient(&self, world_pos: DVec3) -> DVec3 {
        self.0.gradient(world_pos)
    }
    fn gradient_step(&self) -> DVec3 {
        self.0.gradient_step()
    }
    fn value_range(&self, world_box: &volga_core::Aabb) -> (f64, f64) {
        self.0.value_range(world_box)
    }
    fn sample_spacing(&self) -> f64 {
        self.0.sample_spacing()
    }
}

/// The classic sampling: 41³ points on `[−1, 1]³`, spacing 0.05.
pub(crate) fn marschner_lobb_volume() -> DenseVolume {
    let transform = Transform::new(DVec3::splat(-1.0), DVec3::splat(MarschnerLobb::SPACING)).expect("valid transform");
    let grid = Grid::new(transform, UVec3::splat(41)).expect("valid grid");
    let mut volume = DenseVolume::new(grid, 0.0, false).expect("small grid");
    for ijk in grid.index_box().iter() {
        volume
            .density
            .set(ijk, MarschnerLobb::density(transform.voxel_center(ijk)) as f32);
    }
    volume
}

pub(crate) fn camera() -> Camera {
    Camera::look_at(
        DVec3::new(1.5, -2.7, 1.9),
        DVec3::new(0.0, 0.0, -0.05),
        DVec3::Z,
        Projection::Perspective { fov_y_deg: 38.0 },
    )
    .expect("valid camera")
}

fn mode() -> Mode {
    Mode::Iso(Iso {
        value: MarschnerLobb::ISO,
        colour: SurfaceColour::Constant(Vec3::ONE),
    })
}

fn settings(size: u32, step_voxels: f64) -> RenderSettings {
    let mut s = RenderSettings::new(size, size);
    s.sampling.step_voxels = step_voxels;
    s
}

/// The reference image: the analytic signal at the reference step, `s × s` rays per
/// pixel averaged.
pub(crate) fn reference_image(size: u32) -> Image {
    let s = REFERENCE_SUPERSAMPLING;
    let (fine, _) = render(
        &MarschnerLobb,
        &camera(),
        &mode(),
        &settings(size * s, REFERENCE_STEP_VOXELS),
        &NoProgress,
    )
    .expect("valid reference render");
    let mut pixels = Vec::with_capacity((size * size) as usize);
    for y in 0..size {
        for x in 0..size {
            let mut sum = Vec4::ZERO;
            for j in 0..s {
                for i in 0..s {
                    sum += fine.get(x * s + i, y * s + j);
                }
            }
            pixels.push(sum / (s * s) as f32);
        }
    }
    Image {
        width: size,
        height: size,
        pixels,
    }
}

/// First hits of the pixel-centre rays (`None`: the ray misses).
fn hits<F: Field>(field: &F, size: u32, step_world: f64) -> Vec<Option<DVec3>> {
    let cam = camera();
    (0..size * size)
        .into_par_iter()
        .map(|i| {
            let ray = cam.ray((i % size) as f64, (i / size) as f64, size, size);
            first_hit(field, &ray, MarschnerLobb::ISO, step_world).map(|h| h.world_pos)
        })
        .collect()
}

/// The image of `field` at `step_voxels` (timed) and its pixel-centre first hits.
fn render_and_hits<F: Field>(field: &F, size: u32, step_voxels: f64) -> (Image, Vec<Option<DVec3>>, crate::Timing) {
    let (image, timing) = timed(|| {
        render(field, &camera(), &mode(), &settings(size, step_voxels), &NoProgress)
            .expect("valid render")
            .0
    });
    let hits = hits(field, size, step_voxels * MarschnerLobb::SPACING);
    (image, hits, timing)
}

/// RMS over pixels and RGB channels of the difference of two images (linear [0, 1]).
pub(crate) fn image_rms(a: &Image, b: &Image) -> f64 {
    let sum: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| {
            let d = (*p - *q).truncate().as_dvec3();
            d.length_squared()
        })
        .sum();
    (sum / (3 * a.pixels.len()) as f64).sqrt()
}

/// Hits this close (voxels) are the same crossing found from different sample
/// lattices: bisection refines both to 1e-9 voxel, so the difference is rounding.
const SAME_CROSSING_VOXELS: f64 = 1e-6;

/// RMS distance (voxels) between hits where both rays hit (0 for the same crossing),
/// and the fraction of rays where exactly one of them hits.
fn hit_errors(test: &[Option<DVec3>], reference: &[Option<DVec3>]) -> (f64, f64) {
    let (mut sum, mut both, mut disagree) = (0.0, 0usize, 0usize);
    for (a, b) in test.iter().zip(reference) {
        match (a, b) {
            (Some(a), Some(b)) => {
                // Hits closer than the bisection's reach are the same crossing: 0.
                let d = (*a - *b).length();
                if d > SAME_CROSSING_VOXELS * MarschnerLobb::SPACING {
                    sum += d * d;
                }
                both += 1;
            }
            (None, None) => {}
            _ => disagree += 1,
        }
    }
    (
        (sum / both.max(1) as f64).sqrt() / MarschnerLobb::SPACING,
        disagree as f64 / test.len() as f64,
    )
}

fn run(ctx: &Context) -> KnobResult {
    let size = ctx.size.pick(48, 160);
    let steps: &[f64] = ctx.size.pick(&[1.0, 0.25], &[2.0, 1.0, 0.5, 0.25, 0.125, 0.0625]);
    let filters = [(Filter::Nearest, "nearest"), (Filter::Trilinear, "trilinear")];
    ctx.start("render step", steps.len() * (filters.len() + 1) + 1);
    let volume = marschner_lobb_volume();
    let reference = reference_image(size);
    let reference_hits = hits(&MarschnerLobb, size, REFERENCE_STEP_VOXELS * MarschnerLobb::SPACING);
    ctx.setting_done();
    let memory = volume.payload_bytes() + size as u64 * size as u64 * 16;
    let measure = |field: &dyn Fn(f64) -> (Image, Vec<Option<DVec3>>, crate::Timing), step: f64| {
        let (image, test_hits, timing) = field(step);
        let (hit_rms, disagree) = hit_errors(&test_hits, &reference_hits);
        ctx.setting_done();
        Setting::new(format!("{step}"), &[("step_voxels", step)], timing, memory)
            .error("image_rms", image_rms(&image, &reference))
            .error("hit_rms_voxels", hit_rms)
            .error("hit_disagreement", disagree)
    };
    let mut series: Vec<Series> = filters
        .iter()
        .map(|&(filter, name)| {
            let field = Clipped(Sampled::new(&volume, filter));
            let run_at = |step: f64| render_and_hits(&field, size, step);
            Series {
                name: name.to_string(),
                settings: steps.iter().map(|&step| measure(&run_at, step)).collect(),
            }
        })
        .collect();
    // The analytic signal at the same steps: the step's own error, without any
    // reconstruction error.
    let run_at = |step: f64| render_and_hits(&MarschnerLobb, size, step);
    series.push(Series {
        name: "analytic signal (step error alone)".to_string(),
        settings: steps.iter().map(|&step| measure(&run_at, step)).collect(),
    });
    ctx.finish();
    KnobResult {
        id: "render_step",
        title: "Render step and reconstruction filter (Marschner–Lobb)",
        knob: "ray step Δs in voxels (labels) for nearest and trilinear reconstruction of the 41³ Marschner–Lobb volume, and for the analytic signal itself (the step's error alone); iso-surface ρ = ½, lit",
        reference: "the analytic Marschner–Lobb signal rendered with step 1/32 voxel and 2×2 rays per pixel (image), and its first hits along the pixel-centre rays at step 1/32 voxel refined by bisection (hit positions)",
        timed: "render (iso mode, 160² pixels in the full run), all threads",
        metrics: vec![
            Metric {
                id: "image_rms",
                label: "image error, RMS (linear RGB, 0–1)",
            },
            Metric {
                id: "hit_rms_voxels",
                label: "hit position error, RMS (voxels)",
            },
            Metric {
                id: "hit_disagreement",
                label: "rays hitting in one image only (fraction)",
            },
        ],
        series,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volga_render::Ray;

    /// The reference hit against an independent scan: 64× finer steps of our own loop
    /// with bisection to 1e-12; both must be the same crossing (the entry point where
    /// the ray enters the box inside the surface, as the renderer defines it).
    #[test]
    fn reference_hits_match_a_fine_independent_scan() {
        let cam = camera();
        let size = 24;
        let step = REFERENCE_STEP_VOXELS * MarschnerLobb::SPACING;
        let mut compared = 0;
        for i in (0..size * size).step_by(7) {
            let ray: Ray = cam.ray((i % size) as f64, (i / size) as f64, size, size);
            let fast = first_hit(&MarschnerLobb, &ray, MarschnerLobb::ISO, step).map(|h| h.world_pos);
            let slow = scan(&ray, step / 64.0);
            match (fast, slow) {
                (Some(a), Some(b)) => {
                    assert!((a - b).length() < 1e-6, "ray {i}: {a} vs {b}");
                    compared += 1;
                }
                (None, None) => {}
                (a, b) => panic!("ray {i}: {a:?} vs {b:?}"),
            }
        }
        assert!(compared > 20, "{compared}");
    }

    /// First crossing of ½ into ρ ≥ ½ inside the box, by uniform steps and bisection.
    fn scan(ray: &Ray, dt: f64) -> Option<DVec3> {
        let (t0, t1) =
            volga_core::Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).ray_interval(ray.origin, ray.dir)?;
        let f = |t: f64| MarschnerLobb::density(ray.at(t)) - MarschnerLobb::ISO;
        // Entering from the background (0): content at the entry face is a hit there.
        if f(t0) >= 0.0 {
            return Some(ray.at(t0));
        }
        let mut t = t0;
        let mut prev = f(t);
        while t < t1 {
            let next = (t + dt).min(t1);
            let v = f(next);
            if prev < 0.0 && v >= 0.0 {
                let (mut a, mut b) = (t, next);
                while b - a > 1e-12 {
                    let m = 0.5 * (a + b);
                    if f(m) >= 0.0 {
                        b = m
                    } else {
                        a = m
                    }
                }
                return Some(ray.at(b));
            }
            prev = v;
            t = next;
        }
        None
    }

    #[test]
    fn the_sampled_volume_holds_the_signal_at_its_voxels() {
        let v = marschner_lobb_volume();
        let p = v.grid.transform.voxel_center(glam::IVec3::new(20, 20, 20));
        assert_eq!(p, DVec3::ZERO);
        assert!((v.density.get(glam::IVec3::new(20, 20, 20)) as f64 - 0.6).abs() < 1e-7);
    }
}
