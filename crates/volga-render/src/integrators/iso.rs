//! Opaque iso-surfaces: the first crossing into the inside, refined (regula falsi
//! safeguarded by bisection), shaded with survey eq. 9.

use glam::Vec3;
use volga_core::{Crossing, CrossingRay, Field, FieldKind};

use super::{Effect, Effects, Integrator, March};
use crate::error::bad_setting;
use crate::march::{field_colour, march_iso};
use crate::settings::check_finite_nonneg;
use crate::shadow;
use crate::{CellClass, Ray, RenderError, RenderSettings, RenderStats};

/// Colour `C_o` of an iso-surface.
#[derive(Clone, Debug, PartialEq)]
pub enum SurfaceColour {
    /// One linear RGB colour for the whole surface.
    Constant(Vec3),
    /// [`Field::colour`] at the hit; white where the field has none.
    FromField,
}

/// Opaque iso-surface at `value`: the first crossing from outside to inside, the
/// inside decided by [`Field::kind`] (a density is inside where `≥ value`, a
/// signed distance where `≤ value`), refined to 1e-9 sample spacing, shaded with survey eq. 9
/// with the outward normal (`−∇` for densities, `+∇` for signed distances).
#[derive(Clone, Debug, PartialEq)]
pub struct Iso {
    /// The iso value, in the field's value units (a density for densities, a world
    /// distance for signed distances); must be finite (checked as `mode.value`).
    pub value: f64,
    /// The surface colour `C_o`; a constant colour must be finite and ≥ 0 on every channel
    /// (checked as `mode.colour`).
    pub colour: SurfaceColour,
}

impl Iso {
    /// The surface colour at hit point `p`.
    fn colour_at<F: Field + ?Sized>(&self, field: &F, p: glam::DVec3) -> Vec3 {
        match &self.colour {
            SurfaceColour::Constant(c) => *c,
            SurfaceColour::FromField => field_colour(field, p),
        }
    }

    /// The colour of a ray whose crossing the field answered (marched here if it did not).
    fn shade_crossing<F: Field + ?Sized>(
        &self,
        m: &March<'_, F>,
        ray: &Ray,
        interval: (f64, f64),
        crossing: Crossing,
        stats: &mut RenderStats,
    ) -> (Vec3, f32) {
        let hit = match crossing {
            Crossing::At(t) => Some(t),
            Crossing::Miss => None,
            Crossing::NotProvided => march_iso(
                m.field,
                ray,
                m.inward,
                self.value,
                interval,
                m.step,
                m.tol,
                m.grid,
                stats,
            ),
        };
        match hit {
            None => (Vec3::ZERO, 0.0),
            Some(t) => {
                let p = ray.at(t);
                let co = self.colour_at(m.field, p);
                if m.shader.is_general() {
                    // Point lights or shadows: the surface occludes its shadow rays.
                    stats.gradient_evaluations += 1;
                    let outward = m.kind.outward(m.field.gradient(p));
                    let shader = m.shader.for_ray(ray.dir);
                    let rgb = shader.shade_general(co, outward, p, true, |_, l, d| {
                        shadow::iso_visibility(m, self.value, p, l, d, stats)
                    });
                    return (rgb, 1.0);
                }
                (m.shade_at(co, p, ray, stats), 1.0)
            }
        }
    }
}

impl Integrator for Iso {
    fn name(&self) -> &'static str {
        "iso"
    }

    fn validate(&self) -> Result<(), RenderError> {
        if !self.value.is_finite() {
            return Err(bad_setting(
                "mode.value",
                format!("iso value must be finite, got {}", self.value),
            ));
        }
        if let SurfaceColour::Constant(c) = &self.colour {
            check_finite_nonneg("mode.colour", &c.to_array())?;
        }
        Ok(())
    }

    fn effects(&self, settings: &RenderSettings) -> Effects {
        Effects {
            gradients: Effects::shading(settings),
            colour: match self.colour {
                SurfaceColour::FromField => Effect::on("surface colour from the field"),
                SurfaceColour::Constant(_) => Effect::off("constant surface colour"),
            },
            shadows: Effects::shadowing(settings),
            early_ray_termination: Effect::off("iso rays stop at the first hit"),
            empty_space_skipping: Effects::skipping(settings, "skip macro-cells whose value range excludes the iso value"),
        }
    }

    /// Trilinear, central-difference sampled volumes find their crossings exactly in
    /// the packed copy (`iso_packed.rs`) when no shadow rays or point lights are asked for.
    fn packed_path(&self) -> bool {
        true
    }

    fn packed_iso_value(&self) -> Option<f64> {
        Some(self.value)
    }

    /// A cell is skipped when its whole (oriented) range lies on one side of the
    /// iso value; the side is kept so the bracket, and the hit, are unchanged.
    fn classify_cell(&self, lo: f64, hi: f64, kind: FieldKind) -> CellClass {
        let s = kind.inward_sign();
        let (lo, hi) = if s > 0.0 { (lo, hi) } else { (-hi, -lo) };
        let iso = s * self.value;
        if hi < iso {
            CellClass::Outside
        } else if lo > iso {
            CellClass::Inside
        } else {
            CellClass::Active
        }
    }

    fn integrate<F: Field + ?Sized>(
        &self,
        m: &March<'_, F>,
        ray: &Ray,
        interval: (f64, f64),
        stats: &mut RenderStats,
    ) -> (Vec3, f32) {
        // A packed sampled volume: its exact cell-by-cell crossing (`iso_packed.rs`).
        if let Some(packed) = crate::iso_packed::iso_packed(m) {
            let bg = m.field.background();
            let background_below = (interval.0 > 0.0 && !bg.is_nan()).then_some(m.inward * bg < m.inward * self.value);
            let hit = crate::iso_packed::march_iso_packed(
                packed,
                ray,
                m.inward,
                self.value,
                interval,
                m.tol,
                m.iso_mask,
                m.iso_starts.map_or(f64::NEG_INFINITY, |s| s.start(ray)),
                background_below,
                stats,
            );
            return match hit {
                None => (Vec3::ZERO, 0.0),
                Some(t) => {
                    let p = ray.at(t);
                    let co = self.colour_at(m.field, p);
                    (m.shade_at(co, p, ray, stats), 1.0)
                }
            };
        }
        // A field that finds its own crossings (an ADF) answers; the others are marched.
        let crossing = m.field.first_crossing(ray.origin, ray.dir, interval.0, interval.1, self.value);
        self.shade_crossing(m, ray, interval, crossing, stats)
    }

    /// The crossings of all rays asked of the field at once ([`Field::first_crossings`]),
    /// then each ray finished as [`Iso::integrate`] finishes it; the packed path ray by
    /// ray.
    fn integrate_rays<F: Field + ?Sized>(
        &self,
        m: &March<'_, F>,
        rays: &[Ray],
        intervals: &[Option<(f64, f64)>],
        stats: &mut RenderStats,
        out: &mut [(Vec3, f32)],
    ) {
        if crate::iso_packed::iso_packed(m).is_some() {
            return super::integrate_each(self, m, rays, intervals, stats, out);
        }
        let asked: Vec<CrossingRay> = rays
            .iter()
            .zip(intervals)
            .filter_map(|(ray, interval)| {
                interval.map(|(t0, t1)| CrossingRay {
                    world_origin: ray.origin,
                    world_dir: ray.dir,
                    t0,
                    t1,
                })
            })
            .collect();
        let mut crossings = vec![Crossing::NotProvided; asked.len()];
        m.field.first_crossings(&asked, self.value, &mut crossings);
        let mut crossings = crossings.into_iter();
        for ((ray, interval), o) in rays.iter().zip(intervals).zip(out.iter_mut()) {
            *o = match interval {
                Some(interval) => {
                    let crossing = crossings.next().expect("one crossing per ray with an interval");
                    self.shade_crossing(m, ray, *interval, crossing, stats)
                }
                None => (Vec3::ZERO, 0.0),
            };
        }
    }
}

