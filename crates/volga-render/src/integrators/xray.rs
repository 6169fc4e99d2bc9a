//! X-ray: the mean value along the ray.

use glam::Vec3;
use volga_core::{Field, FieldKind};

use super::{grey, Effect, Effects, Integrator, March};
use crate::march::midpoint_lattice_len;
use crate::{CellClass, Ray, RenderSettings, RenderStats};

/// The mean value of the samples inside the bounds, clamped to \[0, 1\], drawn as
/// white with that opacity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct XRay;

impl Integrator for XRay {
    fn name(&self) -> &'static str {
        "xray"
    }

    fn effects(&self, _settings: &RenderSettings) -> Effects {
        Effects::projection(Effect::off("an X-ray sums every sample"))
    }

    /// The mean needs every sample: no macro grid is built.
    fn skips_cells(&self) -> bool {
        false
    }

    fn classify_cell(&self, _lo: f64, _hi: f64, _kind: FieldKind) -> CellClass {
        CellClass::Active
    }

    fn integrate<F: Field + ?Sized>(
        &self,
        m: &March<'_, F>,
        ray: &Ray,
        (t0, t1): (f64, f64),
        stats: &mut RenderStats,
    ) -> (Vec3, f32) {
        let n = midpoint_lattice_len(t0, t1, m.step);
        let (mut sum, mut count) = (0.0f64, 0u64);
        for i in 0..n {
            stats.samples += 1;
            let v = m.field.value(ray.at(t0 + (i as f64 + 0.5) * m.step));
            if !v.is_nan() {
                sum += v;
                count += 1;
            }
        }
        if count == 0 {
            return (Vec3::ZERO, 0.0);
        }
        grey(sum / count as f64)
    }
}
