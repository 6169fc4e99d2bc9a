//! Reconstruction filter × gradient method on the Marschner–Lobb volume (f_M = 6,
//! α = ¼, sampled on 41³): the error of the reconstructed value and of the normal
//! against the analytic signal along camera rays, the image error against the analytic
//! rendering, and the render time; the images themselves are attached to the report
//! (`render_filters_<filter>_<method>.png`, and the reference).

use glam::DVec3;
use rayon::prelude::*;
use volga_core::{Aabb, Field, Filter, GradientMethod, NoProgress, Sampled};
use volga_render::{render, Image, Iso, Mode, RenderSettings, SurfaceColour};

use super::render_step::{camera, image_rms, marschner_lobb_volume, reference_image, Clipped};
use super::{Context, Experiment};
use crate::references::MarschnerLobb;
use crate::{timed, KnobResult, Metric, Series, Setting};

pub const EXPERIMENT: Experiment = Experiment {
    id: "render_filters",
    run,
};

/// Ray step of the rendered images (voxels): small enough that the step's own error
/// is below every filter's (see `render_step`).
const STEP_VOXELS: f64 = 0.25;

/// Errors are measured at least this many voxels inside the sampled box: the cubics
/// read voxels beyond the outer samples, which the 41³ sampling does not have.
const MARGIN_VOXELS: f64 = 2.0;

/// The analytic gradient is ignored where shorter than this (no defined normal).
const MIN_GRADIENT: f64 = 1e-3;

fn mode() -> Mode {
    Mode::Iso(Iso {
        value: MarschnerLobb::ISO,
        colour: SurfaceColour::Constant(glam::Vec3::ONE),
    })
}

/// Squared errors summed along one ray: (value², count, angle² in degrees², count).
type RaySums = (f64, u64, f64, u64);

/// RMS of the value error and of the normal's angle error (degrees) at points every
/// half voxel along `rays × rays` pixel-centre rays of the experiment's camera, inside
/// the box shrunk by [`MARGIN_VOXELS`]. A zero reconstructed gradient where the
/// signal has one (nearest's analytic derivative) counts as 90°.
pub(crate) fn errors_along_rays<F: Field>(field: &F, rays: u32) -> (f64, f64) {
    let h = MarschnerLobb::SPACING;
    let inner = Aabb::new(
        DVec3::splat(-1.0 + MARGIN_VOXELS * h),
        DVec3::splat(1.0 - MARGIN_VOXELS * h),
    );
    let cam = camera();
    let dt = 0.5 * h;
    let per_ray: Vec<RaySums> = (0..rays * rays)
        .into_par_iter()
        .map(|i| {
            let ray = cam.ray((i % rays) as f64, (i / rays) as f64, rays, rays);
            let mut sums = (0.0, 0, 0.0, 0);
            let Some((t0, t1)) = inner.ray_interval(ray.origin, ray.dir) else {
                return sums;
            };
            let mut t = t0 + 0.5 * dt;
            while t <= t1 {
                let p = ray.at(t);
                let dv = field.value(p) - MarschnerLobb::density(p);
                sums.0 += dv * dv;
                sums.1 += 1;
                let exact = MarschnerLobb::density_gradient(p);
                if exact.length() > MIN_GRADIENT {
                    let g = field.gradient(p);
                    let angle = if g.length() > 0.0 {
                        g.normalize()
                            .dot(exact.normalize())
                            .clamp(-1.0, 1.0)
                            .acos()
                            .to_degrees()
                    } else {
                        90.0
                    };
                    sums.2 += angle * angle;
                    sums.3 += 1;
                }
                t += dt;
            }
            sums
        })
        .collect();
    // Summed in ray order: the same figures for any thread count.
    let (mut v, mut nv, mut a, mut na) = (0.0, 0u64, 0.0, 0u64);
    for s in per_ray {
        v += s.0;
        nv += s.1;
        a += s.2;
        na += s.3;
    }
    ((v / nv.max(1) as f64).sqrt(), (a / na.max(1) as f64).sqrt())
}

/// The images [`run`] attaches: the reference, then one per gradient method and filter.
pub(crate) fn attachment_names() -> Vec<String> {
    let mut names = vec!["render_filters_reference.png".to_string()];
    for method in GradientMethod::ALL {
        for filter in Filter::ALL {
            names.push(image_name(filter, method));
        }
    }
    names
}

fn image_name(filter: Filter, method: GradientMethod) -> String {
    format!("render_filters_{}_{}.png", filter.name(), method.name())
}

fn png(image: &Image) -> Vec<u8> {
    let mut bytes = Vec::new();
    volga_io::encode_png(&mut bytes, image.width, image.height, &image.to_rgba8()).expect("PNG into memory");
    bytes
}

fn run(ctx: &Context) -> KnobResult {
    let size = ctx.size.pick(32, 256);
    let rays = ctx.size.pick(12, 96);
    ctx.start("render filters", Filter::ALL.len() * GradientMethod::ALL.len() + 1);
    let volume = marschner_lobb_volume();
    let reference = reference_image(size);
    ctx.attach("render_filters_reference.png", png(&reference));
    ctx.setting_done();
    let mut settings = RenderSettings::new(size, size);
    settings.sampling.step_voxels = STEP_VOXELS;
    let memory = volume.payload_bytes() + size as u64 * size as u64 * 16;
    let series = GradientMethod::ALL
        .iter()
        .map(|&method| {
            let settings = Filter::ALL
                .iter()
                .enumerate()
                .map(|(k, &filter)| {
                    let field = Clipped(Sampled::new(&volume, filter).with_gradient(method));
                    let (image, timing) = timed(|| {
                        render(&field, &camera(), &mode(), &settings, &NoProgress)
                            .expect("valid render")
                            .0
                    });
                    let (value_rms, normal_rms) = errors_along_rays(&field, rays);
                    ctx.attach(&image_name(filter, method), png(&image));
                    ctx.setting_done();
                    Setting::new(filter.name(), &[("filter", k as f64)], timing, memory)
                        .error("value_rms", value_rms)
                        .error("normal_rms_deg", normal_rms)
                        .error("image_rms", image_rms(&image, &reference))
                })
                .collect();
            Series {
                name: format!("gradient: {}", method.name()),
                settings,
            }
        })
        .collect();
    ctx.finish();
    KnobResult {
        id: "render_filters",
        title: "Reconstruction filter and gradient method (Marschner–Lobb)",
        knob: "reconstruction filter (labels: nearest, trilinear, Catmull–Rom a = −½, cubic B-spline) of the 41³ Marschner–Lobb volume (f_M = 6, α = ¼), with gradients by central differences of the reconstruction or by the filter's analytic derivative (one curve each); iso-surface ρ = ½, lit, ray step ¼ voxel",
        reference: "the analytic signal and its analytic gradient at points every ½ voxel along 96×96 camera rays, at least 2 voxels inside the sampled box (value and normal errors; a zero reconstructed gradient counts as 90°); the analytic signal rendered with step 1/32 voxel and 2×2 rays per pixel (image error)",
        timed: "render (iso mode, 256² pixels in the full run, step ¼ voxel), all threads",
        metrics: vec![
            Metric {
                id: "value_rms",
                label: "reconstructed value error along rays, RMS",
            },
            Metric {
                id: "normal_rms_deg",
                label: "normal error along rays, RMS (degrees)",
            },
            Metric {
                id: "image_rms",
                label: "image error, RMS (linear RGB, 0–1)",
            },
        ],
        series,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The along-ray errors are those of the field measured: zero for the analytic
    /// signal itself, and the cubics beat nearest on the sampled volume.
    #[test]
    fn errors_along_rays_measure_the_reconstruction() {
        let (v, n) = errors_along_rays(&MarschnerLobb, 8);
        assert_eq!(v, 0.0);
        assert!(n < 1e-5, "{n}");
        let volume = marschner_lobb_volume();
        let err = |f: Filter| errors_along_rays(&Sampled::new(&volume, f), 8);
        let (nearest, catmull) = (err(Filter::Nearest), err(Filter::CatmullRom));
        assert!(
            catmull.0 < nearest.0 && catmull.1 < nearest.1,
            "{catmull:?} vs {nearest:?}"
        );
    }
}
