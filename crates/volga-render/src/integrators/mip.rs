//! Maximum intensity projection.

use glam::Vec3;
use volga_core::{Field, FieldKind, Line};

use super::{grey, Effects, Integrator, March};
use crate::march::{index_after, midpoint_lattice_len, BATCH};
use crate::{CellClass, Ray, RenderSettings, RenderStats};

/// Maximum intensity projection: grey = max value along the ray, clamped to
/// \[0, 1\], drawn as white with that opacity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Mip;

impl Integrator for Mip {
    fn name(&self) -> &'static str {
        "mip"
    }

    fn effects(&self, settings: &RenderSettings) -> Effects {
        Effects::projection(Effects::skipping(settings, "skip macro-cells that cannot raise the maximum"))
    }

    /// Every cell stays active: whether it can be skipped depends on the maximum
    /// found so far along each ray, compared with the cell's range maximum.
    fn classify_cell(&self, _lo: f64, _hi: f64, _kind: FieldKind) -> CellClass {
        CellClass::Active
    }

    /// Cells whose range maximum cannot raise the current maximum are skipped; the
    /// others are read in runs through [`Field::values_along`].
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
        let mut max = f64::NEG_INFINITY;
        let mut walk = m.grid.map(|g| g.walk(ray, t0 + 0.5 * m.step));
        let mut i = 0u64;
        while i < n {
            let mut end = n;
            if let Some(w) = &mut walk {
                let t = t0 + (i as f64 + 0.5) * m.step;
                let (hi, t_exit) = w.hi_at(t);
                let next = index_after(t_exit, t0, m.step, 0.5, i, n);
                if hi <= max {
                    stats.cells_skipped += 1;
                    i = next;
                    continue;
                }
                end = next;
            }
            let run = (end - i).min(BATCH as u64) as usize;
            m.field.values_along(&line, i, &mut values[..run]);
            stats.samples += run as u64;
            for &v in &values[..run] {
                if v > max {
                    max = v;
                }
            }
            i += run as u64;
        }
        grey(max)
    }
}
