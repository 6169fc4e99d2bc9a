//! One integrator per render mode. Each file owns its mode's parameters and their
//! validation, its macro-cell skip classification, its per-ray integration and the
//! effects it needs; [`Mode`] is generated from the list in [`modes!`] below.

use glam::{DVec3, Vec3, Vec4};
use volga_core::{Aabb, Field, FieldKind};

use crate::macro_grid::MacroGrid;
use crate::shadow::ShadowParams;
use crate::{CellClass, PreIntegrated, Ray, RenderError, RenderSettings, RenderStats, Shader};

/// What one render mode computes along a ray.
///
/// The renderer calls [`validate`](Self::validate) once, builds the macro-cell grid
/// for empty-space skipping with [`classify_cell`](Self::classify_cell) (if
/// [`skips_cells`](Self::skips_cells)), then hands each tile's rays to
/// [`integrate_rays`](Self::integrate_rays), whose default calls
/// [`integrate`](Self::integrate) once per ray. `integrate` is generic over the field, so
/// the per-sample loop is monomorphized: the mode is dispatched once per image, never per
/// sample.
pub trait Integrator: Sync + std::fmt::Debug {
    /// Short name for messages and reports, e.g. `"iso"`.
    fn name(&self) -> &'static str;

    /// Checks the mode's own parameters; errors name them as `mode.<parameter>`. Modes
    /// without parameters keep the default.
    fn validate(&self) -> Result<(), RenderError> {
        Ok(())
    }

    /// The effects the mode needs under `settings` (its lighting and sampling), so
    /// planners ask the mode instead of matching on it.
    fn effects(&self, settings: &RenderSettings) -> Effects;

    /// Whether the mode can use a macro-cell grid at all (an X-ray reads every
    /// sample: no grid is built).
    fn skips_cells(&self) -> bool {
        true
    }

    /// Whether the mode has a packed fast path (`packet.rs`), used when the field packs
    /// itself and the settings allow it; default `false`.
    fn packed_path(&self) -> bool {
        false
    }

    /// What empty-space skipping may do with a macro cell over which the field's
    /// value lies in `[lo, hi]` (conservative, never NaN, possibly infinite), for a
    /// field of `kind`.
    fn classify_cell(&self, lo: f64, hi: f64, kind: FieldKind) -> CellClass;

    /// The pre-integrated table of the mode's classification for `settings` (asked
    /// only when [`Sampling::pre_integration`](crate::Sampling::pre_integration) is
    /// on), over the field's value `domain`. Modes that do not classify keep the
    /// default, `None`.
    fn pre_integrate(&self, settings: &RenderSettings, domain: (f64, f64)) -> Option<PreIntegrated> {
        let _ = (settings, domain);
        None
    }

    /// The iso value whose packed cell mask (`iso_packed.rs`) the renderer builds once
    /// when this mode takes the packed path; `None` (the default) for modes without one.
    fn packed_iso_value(&self) -> Option<f64> {
        None
    }

    /// The opacity (per reference step) a sample of `value` has for shadows, for modes
    /// whose shadows are the transmittance of their classification (volume rendering):
    /// what the light-space pre-pass
    /// ([`ShadowSettings::light_space`](crate::ShadowSettings::light_space)) sweeps.
    /// `None` (the default) for modes that shadow otherwise.
    fn shadow_opacity(&self, value: f64) -> Option<f32> {
        let _ = value;
        None
    }

    /// Premultiplied colour and alpha of one ray over `[t0, t1]` (the ray clipped to
    /// the field's bounds, finite), before the background is composited.
    fn integrate<F: Field + ?Sized>(
        &self,
        march: &March<'_, F>,
        ray: &Ray,
        interval: (f64, f64),
        stats: &mut RenderStats,
    ) -> (Vec3, f32)
    where
        Self: Sized;

    /// [`integrate`](Self::integrate) of many rays (a tile's): `out[i]` is
    /// `integrate(march, &rays[i], interval, stats)` for `intervals[i] = Some(interval)`
    /// and transparent black for `None` (a ray missing the bounds), the same bits. A mode
    /// that can ask the field for all rays at once overrides it (iso asks
    /// [`Field::first_crossings`]); the default integrates ray by ray.
    fn integrate_rays<F: Field + ?Sized>(
        &self,
        march: &March<'_, F>,
        rays: &[Ray],
        intervals: &[Option<(f64, f64)>],
        stats: &mut RenderStats,
        out: &mut [(Vec3, f32)],
    ) where
        Self: Sized,
    {
        integrate_each(self, march, rays, intervals, stats, out)
    }
}

/// [`Integrator::integrate_rays`] ray by ray (its default).
pub(crate) fn integrate_each<F: Field + ?Sized, I: Integrator>(
    integrator: &I,
    march: &March<'_, F>,
    rays: &[Ray],
    intervals: &[Option<(f64, f64)>],
    stats: &mut RenderStats,
    out: &mut [(Vec3, f32)],
) {
    for ((ray, interval), o) in rays.iter().zip(intervals).zip(out.iter_mut()) {
        *o = match interval {
            Some(interval) => integrator.integrate(march, ray, *interval, stats),
            None => (Vec3::ZERO, 0.0),
        };
    }
}

/// One effect a render needs, and why (shown in the build report).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Effect {
    /// Whether the render performs the effect.
    pub enabled: bool,
    /// Why it does or does not run, in a few words for the build report (e.g.
    /// `"disabled in the settings"`).
    pub why: String,
}

impl Effect {
    /// An effect that runs, for the reason `why`.
    pub fn on(why: impl Into<String>) -> Self {
        Effect {
            enabled: true,
            why: why.into(),
        }
    }
    /// An effect that does not run, for the reason `why`.
    pub fn off(why: impl Into<String>) -> Self {
        Effect {
            enabled: false,
            why: why.into(),
        }
    }
}

/// The effects a mode needs for one image, as declared by
/// [`Integrator::effects`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Effects {
    /// Field gradients (shading normals).
    pub gradients: Effect,
    /// The field's colour ([`Field::colour`]).
    pub colour: Effect,
    /// Shadow rays (iso and volume rendering, for the lights that ask).
    pub shadows: Effect,
    /// Rays may stop early.
    pub early_ray_termination: Effect,
    /// Macro cells may be skipped.
    pub empty_space_skipping: Effect,
}

impl Effects {
    /// The gradient effect of a mode that shades with `settings.lighting`.
    pub fn shading(settings: &RenderSettings) -> Effect {
        match settings.lighting.light_count() {
            0 => Effect::off("unlit (no lights, or shading: false)"),
            k => Effect::on(format!("shaded by {k} light(s) (Phong, eq. 9)")),
        }
    }

    /// The skipping effect of a mode that skips macro cells when the settings allow.
    pub fn skipping(settings: &RenderSettings, why: &str) -> Effect {
        if settings.sampling.empty_space_skipping {
            Effect::on(why)
        } else {
            Effect::off("disabled in the settings")
        }
    }

    pub(crate) fn no_shadows() -> Effect {
        Effect::off("the mode casts no shadow rays")
    }

    /// The shadow effect of a mode that shades with `settings.lighting` and casts
    /// shadow rays for the lights that ask (survey eq. 10).
    pub fn shadowing(settings: &RenderSettings) -> Effect {
        let l = &settings.lighting;
        if !l.casts_shadows() {
            return Effect::off("no light casts shadows");
        }
        Effect::on(format!(
            "{} light(s) cast shadows (eq. 10), shadow step {} voxels",
            l.shadows.casters.len(),
            l.shadows.step_voxels
        ))
    }

    /// A projection (MIP, X-ray): unlit, colourless, reading the whole ray.
    pub(crate) fn projection(empty_space_skipping: Effect) -> Effects {
        Effects {
            gradients: Effect::off("a projection image: no shading"),
            colour: Effect::off("a projection reads values only"),
            shadows: Effects::no_shadows(),
            early_ray_termination: Effect::off("projections read the whole ray"),
            empty_space_skipping,
        }
    }
}

/// Per-image constants an integrator reads while marching one ray: the field (with
/// its kind decided once), the world step, the macro-cell grid and the shader.
pub struct March<'a, F: ?Sized> {
    pub(crate) field: &'a F,
    /// `+1` or `−1`: [`FieldKind::inward_sign`] of the field, decided once per image.
    pub(crate) inward: f64,
    pub(crate) kind: FieldKind,
    /// Ray step in world units (rays are unit length, so also in `t`).
    pub(crate) step: f64,
    /// Bisection tolerance in `t`.
    pub(crate) tol: f64,
    /// `step / reference_step` for opacity correction.
    pub(crate) alpha_exponent: f64,
    pub(crate) early_termination_alpha: f32,
    pub(crate) shader: &'a Shader,
    pub(crate) grid: Option<&'a MacroGrid>,
    /// The field's bounds (where shadow rays end).
    pub(crate) bounds: Aabb,
    /// Shadow ray constants (used only when a light casts shadows).
    pub(crate) shadow: ShadowParams,
    /// The pre-integrated table when pre-integration is on (volume rendering).
    pub(crate) preint: Option<&'a PreIntegrated>,
    /// Per light (directional first, then point): its light-space transmittance grid,
    /// when the pre-pass is on and the light has one.
    pub(crate) light_volumes: &'a [Option<crate::light_volume::LightVolume>],
    /// The packed iso path's cell mask, when the renderer built one.
    pub(crate) iso_mask: Option<&'a crate::iso_packed::IsoCellMask>,
    /// The packed iso path's start map of the view, when the renderer built one.
    pub(crate) iso_starts: Option<&'a crate::iso_packed::IsoStarts>,
    /// The packed copy `field` samples, when the renderer took the packed path.
    pub(crate) packed: Option<&'a crate::packed::PackedVolume>,
}

impl<F: Field + ?Sized> March<'_, F> {
    /// The field being rendered.
    pub fn field(&self) -> &F {
        self.field
    }

    /// The field's kind (decided once per image).
    pub fn kind(&self) -> FieldKind {
        self.kind
    }

    /// Ray step in world units.
    pub fn step(&self) -> f64 {
        self.step
    }

    /// Shades `colour` at `p` with the image's lights (survey eq. 9), the normal
    /// oriented outwards by the field's kind; returns `colour` unchanged (and
    /// evaluates no gradient) when unlit.
    #[inline]
    pub fn shade_at(&self, colour: Vec3, p: DVec3, ray: &Ray, stats: &mut RenderStats) -> Vec3 {
        if self.shader.is_lit() {
            stats.gradient_evaluations += 1;
            let outward = self.kind.outward(self.field.gradient(p));
            self.shader.shade(colour, outward, ray.dir)
        } else {
            colour
        }
    }

    /// Opacity correction for the actual step: `α' = 1 − (1 − α)^(Δs/Δs_ref)`.
    #[inline]
    pub fn correct_alpha(&self, alpha: f32) -> f32 {
        if self.alpha_exponent == 1.0 || alpha >= 1.0 {
            alpha
        } else if self.alpha_exponent == 0.5 {
            // The default step (half the reference): a square root instead of `powf`.
            (1.0 - (1.0 - alpha as f64).sqrt()) as f32
        } else {
            (1.0 - (1.0 - alpha as f64).powf(self.alpha_exponent)) as f32
        }
    }
}

/// White at opacity `g` (premultiplied), `g` clamped to \[0, 1\]; nothing for −∞/NaN.
pub(crate) fn grey(g: f64) -> (Vec3, f32) {
    if g.is_nan() || g == f64::NEG_INFINITY {
        return (Vec3::ZERO, 0.0);
    }
    let g = g.clamp(0.0, 1.0) as f32;
    (Vec3::splat(g), g)
}

/// Composites premultiplied `(c, a)` over `background` and returns straight RGBA
/// clamped to \[0, 1\]: `c + (1 − a)·background`, alpha exactly 1 for an opaque
/// background.
pub(crate) fn over_background(background: Vec4, c: Vec3, a: f32) -> Vec4 {
    let bg = background;
    let (c, a) = if c.is_finite() && a.is_finite() {
        (c, a.clamp(0.0, 1.0))
    } else {
        (Vec3::ZERO, 0.0)
    };
    let premult = c + bg.truncate() * (bg.w * (1.0 - a));
    let out = if bg.w >= 1.0 {
        premult.extend(1.0)
    } else {
        let alpha = a + (1.0 - a) * bg.w;
        if alpha > 0.0 {
            (premult / alpha).extend(alpha)
        } else {
            Vec4::ZERO
        }
    };
    out.clamp(Vec4::ZERO, Vec4::ONE)
}

/// The finite ray interval inside `bounds`, if any.
#[inline]
pub(crate) fn clip(bounds: &Aabb, ray: &Ray) -> Option<(f64, f64)> {
    bounds
        .ray_interval(ray.origin, ray.dir)
        .filter(|(t0, t1)| t0.is_finite() && t1.is_finite())
}

/// Registers the modes: declares each integrator's module and generates [`Mode`]
/// (one variant per integrator, named after its type), `From` conversions,
/// [`Mode::integrator`] and the once-per-image dispatch [`Mode::dispatch`].
/// Adding a mode is one new file here plus one line (and its `///` doc, which becomes
/// the variant's) in this list.
macro_rules! modes {
    ($($(#[$doc:meta])* $module:ident :: $ty:ident),* $(,)?) => {
        $(mod $module; pub use $module::*;)*

        /// The registered render modes, one per integrator (a thin convenience over
        /// the [`Integrator`] types: every method forwards to the integrator).
        #[derive(Clone, Debug)]
        pub enum Mode {
            $($(#[$doc])* $ty($ty),)*
        }

        $(impl From<$ty> for Mode {
            fn from(i: $ty) -> Mode {
                Mode::$ty(i)
            }
        })*

        impl Mode {
            /// The mode's integrator, for its validation and effects.
            pub fn integrator(&self) -> &dyn Integrator {
                match self {
                    $(Mode::$ty(i) => i,)*
                }
            }

            /// Calls `job` with the concrete integrator (one dispatch per image).
            pub(crate) fn dispatch<J: ModeJob>(&self, job: J) -> J::Output {
                match self {
                    $(Mode::$ty(i) => job.run(i),)*
                }
            }
        }
    };
}

/// Work generic over the concrete integrator type, run by [`Mode`]'s dispatch.
pub(crate) trait ModeJob {
    type Output;
    fn run<I: Integrator>(self, integrator: &I) -> Self::Output;
}

modes! {
    /// An opaque iso-surface ([`Iso`]).
    iso::Iso,
    /// Direct volume rendering with a classifier ([`Volume`]).
    volume::Volume,
    /// Maximum intensity projection ([`Mip`]).
    mip::Mip,
    /// The mean value along each ray ([`XRay`]).
    xray::XRay,
}
