//! Volumetric shadows (survey eq. 10): the light reaching a sample at `s` is
//! `C_l(s) = C_L · exp(−∫_s^T μ(t) dt)`, the light's colour attenuated along the
//! shadow ray from `s` towards the light (to the light's position for a point light,
//! to the field's bounds for a directional one).
//!
//! * **Volume rendering**: the integral is the discrete product of the same
//!   classification the view rays use, sampled every
//!   [`ShadowSettings::step_voxels`](crate::ShadowSettings::step_voxels) at the mid
//!   points `(k + ½)·h` of the shadow ray: `T = Π_k (1 − α(s_k))^(h/Δs_ref)`, each
//!   opacity corrected for the shadow step exactly as view samples are for theirs
//!   (`(1 − α)^(h/Δs_ref) = exp(−μ·h)` with `μ = −ln(1 − α)/Δs_ref`), so a slab of
//!   constant opacity and thickness `d` gives `exp(−μ·d)` up to the half-step at each
//!   end. Shadow rays classify post-interpolation (with pre-integration on, the view
//!   rays only are pre-integrated).
//! * **Iso-surfaces**: the surface itself occludes: a light is blocked (`T = 0`) when a
//!   shadow-ray sample `k·h`, `k ≥ 1`, lies inside the iso-surface (the first sample
//!   one step away from the hit, so the surface does not shadow its own hit point), and
//!   when it lies behind the surface (`N·L ≤ 0`: no ray is cast).
//!
//! Both walk the image's macro-cell grid when there is one: transparent (iso:
//! outside) cells are skipped and an iso shadow ray entering a cell that is wholly
//! inside stops there, so skipping never changes a shadow. Shadow rays stop once the
//! transmittance is below
//! [`ShadowSettings::min_transmittance`](crate::ShadowSettings::min_transmittance).
//! Only lights named in [`ShadowSettings::casters`](crate::ShadowSettings::casters)
//! cast them; their number and samples are counted in
//! [`RenderStats::shadow_rays`](crate::RenderStats::shadow_rays) and
//! [`RenderStats::shadow_samples`](crate::RenderStats::shadow_samples).

use glam::DVec3;
use volga_core::{Field, Line};

use crate::classify::{Classify, ClassifySample};
use crate::integrators::March;
use crate::march::{index_after, midpoint_lattice_len, BATCH};
use crate::{CellClass, Ray, RenderError, RenderSettings, RenderStats, Sampling};

/// The per-image constants of shadow rays.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShadowParams {
    /// Shadow ray step in world units.
    pub(crate) step: f64,
    /// `shadow step / reference step`: the opacity correction exponent.
    pub(crate) alpha_exponent: f64,
    pub(crate) min_transmittance: f32,
}

impl ShadowParams {
    /// The shadow constants of `settings` for a field with `bounds` and `spacing`,
    /// after checking that a shadow ray needs at most 2²⁴ samples (errors name
    /// `lighting.shadows.step_voxels`).
    pub(crate) fn new(
        settings: &RenderSettings,
        bounds: &volga_core::Aabb,
        spacing: f64,
    ) -> Result<ShadowParams, RenderError> {
        let sh = &settings.lighting.shadows;
        let step = Sampling {
            step_voxels: sh.step_voxels,
            ..settings.sampling.clone()
        }
        .world_step(bounds, spacing)
        .map_err(|e| match e {
            RenderError::BadSetting { reason, .. } => crate::error::bad_setting("lighting.shadows.step_voxels", reason),
            e => e,
        })?;
        Ok(ShadowParams {
            step,
            alpha_exponent: sh.step_voxels / settings.sampling.reference_step_voxels,
            min_transmittance: sh.min_transmittance,
        })
    }
}

/// How far a shadow ray from `p` along unit `dir` runs: to the bounds' exit or the
/// light at `distance`, whichever is nearer; `None` when nothing is left.
#[inline]
fn shadow_ray<F: Field + ?Sized>(m: &March<'_, F>, p: DVec3, dir: DVec3, distance: f64) -> Option<(Ray, f64)> {
    let ray = Ray { origin: p, dir };
    let (_, t1) = m.bounds.ray_interval(p, dir)?;
    let t_end = t1.min(distance);
    (t_end.is_finite() && t_end > 0.0).then_some((ray, t_end))
}

/// Transmittance from `p` towards a light along unit `dir` at `distance` (∞ for a
/// directional light) through the volume classified by `classifier`: the discrete
/// product of eq. 10 (see the module doc).
pub(crate) fn transmittance<F: Field + ?Sized, C: Classify>(
    m: &March<'_, F>,
    classifier: &C,
    p: DVec3,
    dir: DVec3,
    distance: f64,
    stats: &mut RenderStats,
) -> f32 {
    stats.shadow_rays += 1;
    let Some((ray, t_end)) = shadow_ray(m, p, dir, distance) else {
        return 1.0;
    };
    let sp = m.shadow;
    let h = sp.step;
    let n = midpoint_lattice_len(0.0, t_end, h);
    let line = Line {
        origin: ray.at(0.5 * h),
        step: dir * h,
    };
    let mut values = [0.0f64; BATCH];
    let mut walk = m.grid.map(|g| g.walk(&ray, 0.5 * h));
    let mut transmittance = 1.0f64;
    let mut i = 0u64;
    while i < n {
        let mut end = n;
        if let Some(w) = &mut walk {
            let (class, t_exit) = w.class_at((i as f64 + 0.5) * h);
            let next = index_after(t_exit, 0.0, h, 0.5, i, n);
            if class != CellClass::Active {
                i = next;
                continue;
            }
            end = next;
        }
        let run = (end - i).min(BATCH as u64) as usize;
        m.field.values_along(&line, i, &mut values[..run]);
        stats.shadow_samples += run as u64;
        for (k, &v) in values[..run].iter().enumerate() {
            if v.is_nan() {
                continue;
            }
            let alpha = classifier
                .classify(&ClassifySample {
                    value: v,
                    previous_value: f64::NAN,
                    world_pos: line.at(i + k as u64),
                })
                .w;
            if alpha > 0.0 {
                transmittance *= if alpha >= 1.0 {
                    0.0
                } else {
                    (1.0 - alpha as f64).powf(sp.alpha_exponent)
                };
                if transmittance <= sp.min_transmittance as f64 {
                    return 0.0;
                }
            }
        }
        i += run as u64;
    }
    transmittance as f32
}

/// Visibility (0 or 1) of a light from the iso-surface point `p` along unit `dir` at
/// `distance`: 0 when a shadow-ray sample `k·h`, `k ≥ 1`, is inside the surface
/// (`inward·value ≥ inward·iso`). See the module doc.
pub(crate) fn iso_visibility<F: Field + ?Sized>(
    m: &March<'_, F>,
    iso: f64,
    p: DVec3,
    dir: DVec3,
    distance: f64,
    stats: &mut RenderStats,
) -> f32 {
    stats.shadow_rays += 1;
    let Some((ray, t_end)) = shadow_ray(m, p, dir, distance) else {
        return 1.0;
    };
    let h = m.shadow.step;
    // Samples at (j + 1)·h ≤ t_end, j = 0..n: a midpoint lattice from ½h.
    let n = midpoint_lattice_len(0.5 * h, t_end, h);
    let line = Line {
        origin: ray.at(h),
        step: dir * h,
    };
    let iso = m.inward * iso;
    let mut values = [0.0f64; BATCH];
    let mut walk = m.grid.map(|g| g.walk(&ray, h));
    let mut i = 0u64;
    while i < n {
        let mut end = n;
        if let Some(w) = &mut walk {
            let (class, t_exit) = w.class_at((i as f64 + 1.0) * h);
            match class {
                CellClass::Inside => return 0.0,
                CellClass::Outside => {
                    i = index_after(t_exit, h, h, 0.0, i, n);
                    continue;
                }
                CellClass::Active => end = index_after(t_exit, h, h, 0.0, i, n),
            }
        }
        let run = (end - i).min(BATCH as u64) as usize;
        m.field.values_along(&line, i, &mut values[..run]);
        stats.shadow_samples += run as u64;
        if values[..run].iter().any(|&v| m.inward * v >= iso) {
            return 0.0;
        }
        i += run as u64;
    }
    1.0
}

#[cfg(test)]
mod tests {
    use glam::Vec4;
    use volga_core::{Aabb, FieldKind};

    use super::*;
    use crate::{Iso, LightId, Renderer, SurfaceColour, TransferFunction, Volume};

    /// Density 1 in the slab `a ≤ x ≤ b`, 0 elsewhere, in the box ±4, sampled every 0.1.
    struct Slab {
        a: f64,
        b: f64,
    }

    impl Field for Slab {
        fn bounds(&self) -> Aabb {
            Aabb::new(DVec3::splat(-4.0), DVec3::splat(4.0))
        }
        fn value(&self, p: DVec3) -> f64 {
            if (self.a..=self.b).contains(&p.x) {
                1.0
            } else {
                0.0
            }
        }
        fn sample_spacing(&self) -> f64 {
            0.1
        }
        fn gradient_step(&self) -> DVec3 {
            DVec3::splat(0.05)
        }
        fn value_range(&self, b: &Aabb) -> (f64, f64) {
            let lo = if b.min.x >= self.a && b.max.x <= self.b {
                1.0
            } else {
                0.0
            };
            let hi = if b.max.x >= self.a && b.min.x <= self.b {
                1.0
            } else {
                0.0
            };
            (lo, hi)
        }
    }

    fn settings(shadow_step_voxels: f64, skipping: bool) -> RenderSettings {
        let mut s = RenderSettings::new(4, 4);
        s.sampling.empty_space_skipping = skipping;
        s.lighting.shadows.casters = vec![LightId::Directional(0)];
        s.lighting.shadows.step_voxels = shadow_step_voxels;
        s.lighting.shadows.min_transmittance = 0.0;
        s
    }

    /// Opacity 0.2 per reference step (one sample spacing, 0.1) at density 1.
    fn tf() -> TransferFunction {
        TransferFunction::new(vec![(0.0, Vec4::ZERO), (1.0, Vec4::new(1.0, 1.0, 1.0, 0.2))]).unwrap()
    }

    #[test]
    fn slab_transmittance_is_the_discrete_product_and_near_exp_minus_tau_d() {
        let (a, b) = (-1.03, 0.61); // thickness d = 1.64 world units
        let field = Slab { a, b };
        let p = DVec3::new(-3.0, 0.2, 0.1);
        let tf = tf();
        let volume = Volume::new(tf.clone(), false);
        // μ per world unit: −ln(1 − 0.2)/0.1.
        let mu = -(0.8f64).ln() / 0.1;
        let exact = (-mu * (b - a)).exp();
        for step_voxels in [0.25, 0.5, 1.0, 2.0] {
            let h = step_voxels * 0.1;
            // Mid-point samples (k + ½)·h from p.x = −3 inside [a, b].
            let inside = (0..400)
                .map(|k| p.x + (k as f64 + 0.5) * h)
                .filter(|x| (a..=b).contains(x) && *x <= 4.0)
                .count();
            let discrete = 0.8f64.powf(inside as f64 * step_voxels);
            let mut results = Vec::new();
            for skipping in [false, true] {
                let s = settings(step_voxels, skipping);
                let r = Renderer::new(&field, &volume, &s).unwrap();
                let m = r.march(&field);
                let mut stats = RenderStats::default();
                let t = transmittance(&m, &tf, p, DVec3::X, f64::INFINITY, &mut stats);
                assert_eq!(stats.shadow_rays, 1);
                assert!(stats.shadow_samples > 0);
                assert!(
                    ((t as f64) - discrete).abs() < 1e-6 * discrete,
                    "{step_voxels}: {t} vs {discrete}"
                );
                // The discrete sum covers d to within half a step at each end.
                let tol = (mu * h).exp();
                assert!(
                    (t as f64) <= exact * tol && (t as f64) >= exact / tol,
                    "{step_voxels}: {t} vs exp(−τd) = {exact}"
                );
                results.push(t.to_bits());
                // A point light between p and the slab: nothing in the way.
                let mut stats = RenderStats::default();
                let t = transmittance(&m, &tf, p, DVec3::X, 0.9, &mut stats);
                assert_eq!(t, 1.0);
            }
            assert_eq!(results[0], results[1], "skipping changes the shadow");
        }
    }

    #[test]
    fn an_iso_surface_blocks_the_light_behind_it() {
        let field = Slab { a: -1.0, b: 1.0 };
        let iso = Iso {
            value: 0.5,
            colour: SurfaceColour::Constant(glam::Vec3::ONE),
        };
        for skipping in [false, true] {
            let s = settings(1.0, skipping);
            let r = Renderer::new(&field, &iso, &s).unwrap();
            let m = r.march(&field);
            assert_eq!(m.kind, FieldKind::Density);
            let mut stats = RenderStats::default();
            // On the slab's −x face, the light along +x is behind the slab.
            let p = DVec3::new(-1.0, 0.0, 0.0);
            assert_eq!(iso_visibility(&m, 0.5, p, DVec3::X, f64::INFINITY, &mut stats), 0.0);
            // Towards −x nothing is in the way; a point light short of the slab too.
            assert_eq!(iso_visibility(&m, 0.5, p, -DVec3::X, f64::INFINITY, &mut stats), 1.0);
            let q = DVec3::new(-3.0, 0.0, 0.0);
            assert_eq!(iso_visibility(&m, 0.5, q, DVec3::X, 1.5, &mut stats), 1.0);
            assert_eq!(iso_visibility(&m, 0.5, q, DVec3::X, 2.5, &mut stats), 0.0);
            assert_eq!(stats.shadow_rays, 4);
        }
    }
}
