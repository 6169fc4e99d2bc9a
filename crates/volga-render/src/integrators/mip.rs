//! Maximum intensity projection.

use glam::Vec3;
use volga_core::{Field, FieldKind};

use super::{grey, Effects, Integrator, March};
use crate::march::{index_after, midpoint_lattice_len};
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

    /// Cells whose range maximum cannot raise the current maximum are skipped.
    fn integrate<F: Field + ?Sized>(
        &self,
        m: &March<'_, F>,
        ray: &Ray,
        (t0, t1): (f64, f64),
        stats: &mut RenderStats,
    ) -> (Vec3, f32) {
        let n = midpoint_lattice_len(t0, t1, m.step);
        let mut max = f64::NEG_INFINITY;
        let mut i = 0u64;
        while i < n {
            let t = t0 + (i as f64 + 0.5) * m.step;
            if let Some(g) = &m.grid {
                let (hi, t_exit) = g.hi_at(ray, t);
                if hi <= max {
                    stats.cells_skipped += 1;
                    i = index_after(t_exit, t0, m.step, 0.5, i, n);
                    continue;
                }
            }
            i += 1;
            stats.samples += 1;
            let v = m.field.value(ray.at(t));
            if v > max {
                max = v;
            }
        }
        grey(max)
    }
}
