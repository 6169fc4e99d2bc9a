//! Direct volume rendering: classified samples composited front to back.

use glam::{DVec3, Vec3};
use volga_core::{Field, FieldKind, Line};

use super::{Effect, Effects, Integrator, March};
use crate::classify::{Classifier, Classify, ClassifySample};
use crate::march::{field_colour, index_after, midpoint_lattice_len, BATCH};
use crate::shadow;
use crate::{CellClass, PreIntegrated, Ray, RenderError, RenderSettings, RenderStats, TransferFunction};

/// Direct volume rendering: samples classified by [`Classifier`] (today the
/// post-classified 1D transfer function, survey eq. 15) and composited front to
/// back (survey eq. 13) with opacity correction and early ray termination. With
/// `colour_from_field` the RGB comes from [`Field::colour`] (white if none) and only
/// the opacity from the classifier.
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    /// Maps each sample to straight RGBA, its opacity defined per
    /// [`Sampling::reference_step_voxels`](crate::Sampling::reference_step_voxels); valid
    /// by construction.
    pub classifier: Classifier,
    /// Take the RGB from [`Field::colour`] (white where the field has none) and only the
    /// opacity from the classifier. Turns off the packed fast path.
    pub colour_from_field: bool,
}

impl Volume {
    /// Post-classified volume rendering with a 1D transfer function.
    pub fn new(transfer: TransferFunction, colour_from_field: bool) -> Self {
        Volume {
            classifier: Classifier::Transfer(transfer),
            colour_from_field,
        }
    }
}

impl Integrator for Volume {
    fn name(&self) -> &'static str {
        "volume"
    }

    /// Classifiers are valid by construction ([`TransferFunction::new`] checks).
    fn validate(&self) -> Result<(), RenderError> {
        Ok(())
    }

    fn effects(&self, settings: &RenderSettings) -> Effects {
        let sampling = &settings.sampling;
        Effects {
            gradients: Effects::shading(settings),
            colour: if self.colour_from_field {
                Effect::on("sample colour from the field")
            } else {
                Effect::off("colour from the transfer function")
            },
            shadows: Effects::shadowing(settings),
            early_ray_termination: if sampling.early_termination() {
                Effect::on(format!(
                    "stop rays once opacity reaches {}",
                    sampling.early_termination_alpha
                ))
            } else {
                Effect::off("disabled in the settings")
            },
            empty_space_skipping: Effects::skipping(settings, "skip macro-cells whose value range is invisible"),
        }
    }

    /// A 1D transfer function with the classifier's colour composites in the packed loop.
    fn packed_path(&self) -> bool {
        matches!(self.classifier, Classifier::Transfer(_)) && !self.colour_from_field
    }

    /// Transparent cells (zero opacity over the cell's range) are skipped.
    fn classify_cell(&self, lo: f64, hi: f64, _kind: FieldKind) -> CellClass {
        if self.classifier.max_alpha(lo, hi) == 0.0 {
            CellClass::Outside
        } else {
            CellClass::Active
        }
    }

    /// The transfer function pre-integrated for the image's step (survey §7).
    fn pre_integrate(&self, settings: &RenderSettings, domain: (f64, f64)) -> Option<PreIntegrated> {
        let s = &settings.sampling;
        match &self.classifier {
            Classifier::Transfer(tf) => Some(PreIntegrated::new(
                tf,
                domain,
                s.step_voxels / s.reference_step_voxels,
                crate::PRE_INTEGRATION_TABLE_SIZE,
            )),
        }
    }

    /// The transfer function's opacity at `value` (post-classified).
    fn shadow_opacity(&self, value: f64) -> Option<f32> {
        match &self.classifier {
            Classifier::Transfer(tf) => Some(tf.eval(value).w),
        }
    }

    fn integrate<F: Field + ?Sized>(
        &self,
        m: &March<'_, F>,
        ray: &Ray,
        interval: (f64, f64),
        stats: &mut RenderStats,
    ) -> (Vec3, f32) {
        let colour = self.colour_from_field;
        match (&self.classifier, m.preint) {
            (Classifier::Transfer(tf), None) => match (m.packed, tf.lanes()) {
                (Some(p), Some(lanes)) if !colour => crate::packet::composite(m, p, lanes, ray, interval, stats),
                _ => composite(m, &PostClassified(tf), tf, colour, ray, interval, stats),
            },
            (Classifier::Transfer(tf), Some(t)) => composite(m, &PreClassified(t), tf, colour, ray, interval, stats),
        }
    }
}

/// How a sample (with the value before it on the ray) becomes straight colour and
/// opacity corrected for the step: post-classification then opacity correction, or a
/// pre-integrated segment lookup. Monomorphized in [`composite`].
trait Segment {
    /// Whether segments reach back to the previous sample (empty-space skipping must
    /// then keep the samples at both ends of a skipped run).
    const PRE_INTEGRATED: bool;

    /// Straight RGB and corrected opacity; opacity ≤ 0 or NaN is invisible.
    fn classify<F: Field + ?Sized>(&self, m: &March<'_, F>, sample: &ClassifySample, cache: &mut (f32, f32))
        -> (Vec3, f32);
}

struct PostClassified<'c, C>(&'c C);

impl<C: Classify> Segment for PostClassified<'_, C> {
    const PRE_INTEGRATED: bool = false;

    #[inline]
    fn classify<F: Field + ?Sized>(
        &self,
        m: &March<'_, F>,
        sample: &ClassifySample,
        corrected: &mut (f32, f32),
    ) -> (Vec3, f32) {
        let rgba = self.0.classify(sample);
        if rgba.w.is_nan() || rgba.w <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        if corrected.0 != rgba.w {
            *corrected = (rgba.w, m.correct_alpha(rgba.w));
        }
        (rgba.truncate(), corrected.1)
    }
}

struct PreClassified<'t>(&'t PreIntegrated);

impl Segment for PreClassified<'_> {
    const PRE_INTEGRATED: bool = true;

    /// The segment from the previous sample (the sample itself at a ray's start or
    /// after a NaN), already integrated over the step.
    #[inline]
    fn classify<F: Field + ?Sized>(&self, _m: &March<'_, F>, sample: &ClassifySample, _: &mut (f32, f32)) -> (Vec3, f32) {
        let front = if sample.previous_value.is_nan() {
            sample.value
        } else {
            sample.previous_value
        };
        let rgba = self.0.lookup(front, sample.value);
        if rgba.w <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        ((rgba.truncate() / rgba.w).min(Vec3::ONE), rgba.w)
    }
}

/// Front-to-back compositing (survey eq. 13): `c += C·α'·(1 − a)`, `a += α'·(1 − a)`
/// at `t0 + (i + ½)·Δs`, stopping once `a ≥ early_termination_alpha`. Returns
/// premultiplied colour and alpha. Generic over the classifier, which it never
/// inspects beyond [`Classify`].
///
/// Samples are read in runs (one macro cell, at most [`BATCH`]) through
/// [`Field::values_along`]; the run is classified, the gradients of its visible
/// samples are read in one [`Field::gradients_at`] call, then the run is composited in
/// order. Every value, gradient and sum is a function of the sample's index alone, so
/// skipping and the run boundaries never change the image.
///
/// With a pre-integrated [`Segment`], a skipped run of samples keeps its first sample
/// (the segment entering it) and resumes at its last (the segment leaving it starts
/// there); the segments between lie inside the cell, whose table entries are all
/// transparent ([`PreIntegrated::max_alpha`]), so skipping still never changes the
/// image. Shading with point lights or shadows goes through the general shader, whose
/// shadow rays classify with `shadow_classifier` ([`shadow::transmittance`]).
fn composite<F: Field + ?Sized, S: Segment, C: Classify>(
    m: &March<'_, F>,
    classifier: &S,
    shadow_classifier: &C,
    colour_from_field: bool,
    ray: &Ray,
    (t0, t1): (f64, f64),
    stats: &mut RenderStats,
) -> (Vec3, f32) {
    let n = midpoint_lattice_len(t0, t1, m.step);
    let line = Line {
        origin: ray.at(t0 + 0.5 * m.step),
        step: ray.dir * m.step,
    };
    let lit = m.shader.is_lit();
    let shader = m.shader.for_ray(ray.dir);
    let mut values = [0.0f64; BATCH];
    // The run's visible samples: world position, corrected alpha, colour.
    let mut visible_pos = [DVec3::ZERO; BATCH];
    let mut visible = [(0.0f32, Vec3::ZERO); BATCH];
    let mut gradients = [DVec3::ZERO; BATCH];
    let mut c = Vec3::ZERO;
    let mut a = 0.0f32;
    let mut previous_value = f64::NAN;
    // The last opacity corrected and its correction (uniform regions repeat it): one
    // `powf` per change instead of per sample, the same bits.
    let mut corrected = (f32::NAN, f32::NAN);
    let mut walk = m.grid.map(|g| g.walk(ray, t0 + 0.5 * m.step));
    let general = m.shader.is_general();
    let mut i = 0u64;
    while i < n {
        let mut end = n;
        let mut skip_to = 0u64;
        if let Some(w) = &mut walk {
            let t = t0 + (i as f64 + 0.5) * m.step;
            let (class, t_exit) = w.class_at(t);
            let next = index_after(t_exit, t0, m.step, 0.5, i, n);
            if class != CellClass::Active && !S::PRE_INTEGRATED {
                // Transparent cell: every sample in it has α = 0 and would be skipped.
                stats.cells_skipped += 1;
                i = next;
                previous_value = f64::NAN;
                continue;
            }
            if class != CellClass::Active && next - i >= 3 {
                // Pre-integrated: composite sample `i` (the segment entering the cell),
                // skip to the cell's last sample `next − 1`.
                stats.cells_skipped += 1;
                skip_to = next - 1;
                end = i + 1;
            } else {
                end = next;
            }
        }
        let run = (end - i).min(BATCH as u64) as usize;
        m.field.values_along(&line, i, &mut values[..run]);
        stats.samples += run as u64;
        let mut count = 0;
        for (k, &v) in values[..run].iter().enumerate() {
            let p = line.at(i + k as u64);
            let sample = ClassifySample {
                value: v,
                previous_value,
                world_pos: p,
            };
            previous_value = v;
            if v.is_nan() {
                continue;
            }
            let (rgb, alpha) = classifier.classify(m, &sample, &mut corrected);
            if alpha.is_nan() || alpha <= 0.0 {
                continue;
            }
            let co = if colour_from_field { field_colour(m.field, p) } else { rgb };
            visible_pos[count] = p;
            visible[count] = (alpha, co);
            count += 1;
        }
        i += run as u64;
        if skip_to > i {
            i = skip_to;
            previous_value = f64::NAN;
        }
        if count == 0 {
            continue;
        }
        if lit {
            m.field.gradients_at(&visible_pos[..count], &mut gradients[..count]);
            stats.gradient_evaluations += count as u64;
        }
        for k in 0..count {
            let (alpha, co) = visible[k];
            let rgb = if !lit {
                co
            } else if general {
                let p = visible_pos[k];
                shader.shade_general(co, m.kind.outward(gradients[k]), p, false, |light, l, d| {
                    match m.light_volumes.get(light) {
                        Some(Some(volume)) => {
                            stats.shadow_lookups += 1;
                            volume.at(p)
                        }
                        _ => shadow::transmittance(m, shadow_classifier, p, l, d, stats),
                    }
                })
            } else {
                shader.shade(co, m.kind.outward(gradients[k]))
            };
            let w = (1.0 - a) * alpha;
            c += rgb * w;
            a += w;
            if a >= m.early_termination_alpha {
                stats.rays_terminated_early += 1;
                return (c, a);
            }
        }
    }
    (c, a)
}
