//! X-ray: the mean value along the ray.

use glam::Vec3;
use volga_core::{Field, FieldKind, Line};

use super::{grey, Effect, Effects, Integrator, March};
use crate::march::{midpoint_lattice_len, BATCH};
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
        let line = Line {
            origin: ray.at(t0 + 0.5 * m.step),
            step: ray.dir * m.step,
        };
        let mut values = [0.0f64; BATCH];
        let (mut sum, mut count) = (0.0f64, 0u64);
        let mut i = 0u64;
        while i < n {
            let run = (n - i).min(BATCH as u64) as usize;
            m.field.values_along(&line, i, &mut values[..run]);
            stats.samples += run as u64;
            for &v in &values[..run] {
                if !v.is_nan() {
                    sum += v;
                    count += 1;
                }
            }
            i += run as u64;
        }
        if count == 0 {
            return (Vec3::ZERO, 0.0);
        }
        grey(sum / count as f64)
    }
}
