//! Render settings, grouped by what they control, and their one validation.

use glam::{DVec3, Vec3, Vec4};
use volga_core::Aabb;

use crate::error::bad_setting;
use crate::march::MAX_STEPS_PER_RAY;
use crate::{Light, LightId, Material, PointLight, RenderError};

/// Largest image rendered (pixels), so a typo cannot ask for terabytes.
pub const MAX_PIXELS: u64 = 1 << 28;

/// Largest number of lattice samples one ray may take (2²⁴).
pub const MAX_SAMPLES_PER_RAY: u64 = 1 << 24;

/// The picture: its size, what lies behind the content, and how it is tiled.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageSettings {
    /// Image width in pixels; ≥ 1, with `width × height ≤` [`MAX_PIXELS`]; default 512.
    pub width: u32,
    /// Image height in pixels; ≥ 1; default 512.
    pub height: u32,
    /// Straight RGBA composited behind everything; default (0.05, 0.05, 0.08, 1).
    pub background: Vec4,
    /// Edge of the square pixel tiles rendered in parallel; default 16. Never
    /// changes the image.
    pub tile_size: u32,
    /// Rays per pixel along each axis: `k × k` rays through the centres of a
    /// regular `k × k` grid of sub-pixels, their premultiplied colours averaged before
    /// the background is composited (anti-aliasing silhouettes and edges). 1 to
    /// [`MAX_SUPERSAMPLING`]; default 1 (one ray through the pixel centre).
    pub supersampling: u32,
}

/// Largest [`ImageSettings::supersampling`] (256 rays per pixel).
pub const MAX_SUPERSAMPLING: u32 = 16;

impl Default for ImageSettings {
    fn default() -> Self {
        ImageSettings {
            width: 512,
            height: 512,
            background: Vec4::new(0.05, 0.05, 0.08, 1.0),
            tile_size: 16,
            supersampling: 1,
        }
    }
}

/// How rays are sampled and when they may stop or skip.
#[derive(Clone, Debug, PartialEq)]
pub struct Sampling {
    /// Ray step as a fraction of [`Field::sample_spacing`](volga_core::Field::sample_spacing);
    /// default 0.5.
    pub step_voxels: f64,
    /// Step (in sample spacings) the transfer function's opacities are defined
    /// for; default 1.0. Opacities are corrected to `α' = 1 − (1 − α)^(step/reference)`.
    pub reference_step_voxels: f64,
    /// Volume rays stop once accumulated alpha reaches this; default 0.99 (values
    /// above 1 disable early ray termination).
    pub early_termination_alpha: f32,
    /// Skip macro cells that cannot contribute (never changes the image); default on.
    pub empty_space_skipping: bool,
    /// Sample the field [`Field::prepare`](volga_core::Field::prepare) returns (a
    /// sampled volume's brick atlas: the same bits, faster) instead of the field
    /// itself; default on. Never changes the image.
    pub prepare_field: bool,
    /// Render trilinear, central-difference sampled volumes through the packed fast path
    /// (per-voxel gradients, `f32` shading; see `packet.rs` in this crate): the same
    /// image within 1/255 per channel, faster; default on. Fields that are not such a
    /// reconstruction of voxels ([`Field::voxels`](volga_core::Field::voxels)) ignore it.
    pub packed_path: bool,
    /// Pre-integrated classification (Engel et al., survey §7 "transfer functions"):
    /// volume rendering looks up each ray segment `(s_front, s_back)` in a 2D table
    /// built once per transfer function and step, instead of classifying the sample
    /// alone, so sharp transfer functions show no slab artefacts at large steps.
    /// Default off (the table costs a build and a bilinear lookup per sample).
    pub pre_integration: bool,
}

impl Default for Sampling {
    fn default() -> Self {
        Sampling {
            step_voxels: 0.5,
            reference_step_voxels: 1.0,
            early_termination_alpha: 0.99,
            empty_space_skipping: true,
            prepare_field: true,
            packed_path: true,
            pre_integration: false,
        }
    }
}

impl Sampling {
    /// Whether early ray termination can stop a ray (`early_termination_alpha ≤ 1`).
    pub fn early_termination(&self) -> bool {
        self.early_termination_alpha <= 1.0
    }

    /// The ray step in world units for a field with `bounds` and `sample_spacing`
    /// (what [`Field::bounds`](volga_core::Field::bounds) and
    /// [`Field::sample_spacing`](volga_core::Field::sample_spacing) return), after
    /// checking that a ray crossing the bounds needs at most
    /// [`MAX_SAMPLES_PER_RAY`] samples.
    ///
    /// This is the check [`render`](crate::render) runs; a scene can run it at
    /// validation time with the bounds and spacing of the field it will render
    /// (for a sampled grid: [`Grid::sampled_bounds`](volga_core::Grid::sampled_bounds)
    /// and the smallest voxel spacing).
    ///
    /// Errors: bounds not finite or empty, spacing not finite and positive, a step
    /// that is not finite and positive, or too many samples (named
    /// `sampling.step_voxels`).
    pub fn world_step(&self, bounds: &Aabb, sample_spacing: f64) -> Result<f64, RenderError> {
        if !(bounds.min.is_finite() && bounds.max.is_finite()) || bounds.is_empty() {
            return Err(RenderError::BadFieldBounds {
                min: bounds.min.to_array(),
                max: bounds.max.to_array(),
            });
        }
        if !(sample_spacing.is_finite() && sample_spacing > 0.0) {
            return Err(RenderError::BadSampleSpacing(sample_spacing));
        }
        let step = self.step_voxels * sample_spacing;
        let diagonal = bounds.size().length();
        let steps = diagonal / step;
        if !(step.is_finite() && step > 0.0 && steps.is_finite() && steps <= MAX_STEPS_PER_RAY) {
            return Err(bad_setting(
                "sampling.step_voxels",
                format!(
                    "step of {step} world units needs more than {MAX_STEPS_PER_RAY} samples to cross the field bounds (diagonal {diagonal})"
                ),
            ));
        }
        Ok(step)
    }
}

/// Blinn-Phong lighting (survey eq. 9), with volumetric shadows (eq. 10) for the
/// lights [`ShadowSettings::casters`] names.
#[derive(Clone, Debug, PartialEq)]
pub struct Lighting {
    /// Directional lights; with no point lights either, the image is unlit and no
    /// gradient is evaluated. Default: one white light from direction (1, 1, 1).
    pub lights: Vec<Light>,
    /// Point lights (coloured, optionally attenuated with distance); default none.
    pub point_lights: Vec<PointLight>,
    /// Which lights cast volumetric shadows and how finely shadow rays sample;
    /// default: no light casts shadows (no shadow ray is cast).
    pub shadows: ShadowSettings,
    /// Ambient colour `C_a` of survey eq. 9; default white.
    pub ambient_colour: Vec3,
    /// Blinn-Phong coefficients of every surface and sample; default
    /// [`Material::default`]. Unused when unlit.
    pub material: Material,
}

impl Default for Lighting {
    fn default() -> Self {
        Lighting {
            lights: vec![Light {
                direction: DVec3::ONE,
                colour: Vec3::ONE,
            }],
            point_lights: Vec::new(),
            shadows: ShadowSettings::default(),
            ambient_colour: Vec3::ONE,
            material: Material::default(),
        }
    }
}

/// Volumetric shadows (survey eq. 10): the light reaching a sample is its colour
/// times the transmittance along the shadow ray towards the light. Only the lights
/// listed in `casters` cast shadow rays.
#[derive(Clone, Debug, PartialEq)]
pub struct ShadowSettings {
    /// The lights that cast shadows; empty (the default) casts no shadow ray.
    pub casters: Vec<LightId>,
    /// Shadow ray step as a fraction of the field's sample spacing (the quality
    /// knob: smaller is more accurate and slower); default 1.0.
    pub step_voxels: f64,
    /// Shadow rays stop once the transmittance falls below this (the light is then
    /// taken as fully blocked); default 1/256, 0 disables the cut-off.
    pub min_transmittance: f32,
    /// Directional lights' shadows in volume rendering from a light-space pre-pass
    /// (one transmittance grid per light, swept once per image at the shadow step and
    /// read trilinearly) instead of a shadow ray per shaded sample; default off.
    /// Point lights and iso-surfaces always cast shadow rays.
    pub light_space: bool,
}

impl Default for ShadowSettings {
    fn default() -> Self {
        ShadowSettings {
            casters: Vec::new(),
            step_voxels: 1.0,
            min_transmittance: 1.0 / 256.0,
            light_space: false,
        }
    }
}

impl Lighting {
    /// No lights: surfaces and samples keep their colour, no gradient is evaluated.
    pub fn unlit() -> Self {
        Lighting {
            lights: Vec::new(),
            ..Lighting::default()
        }
    }

    /// Whether any light shines (and so whether shading modes need gradients).
    pub fn is_lit(&self) -> bool {
        !self.lights.is_empty() || !self.point_lights.is_empty()
    }

    /// Number of lights, directional and point.
    pub fn light_count(&self) -> usize {
        self.lights.len() + self.point_lights.len()
    }

    /// Whether any light that shines casts shadows (and so whether shadow rays are cast).
    pub fn casts_shadows(&self) -> bool {
        self.shadows.casters.iter().any(|c| match *c {
            LightId::Directional(i) => i < self.lights.len(),
            LightId::Point(i) => i < self.point_lights.len(),
        })
    }

    /// Plain lighting: directional lights only and no shadows (what a fast path that
    /// knows only directional Blinn-Phong may render).
    pub fn is_plain(&self) -> bool {
        self.point_lights.is_empty() && !self.casts_shadows()
    }
}

/// Everything [`render`](crate::render) needs besides the field, camera and mode,
/// in three groups. Checked by [`RenderSettings::validate`], the one place render
/// settings are validated.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderSettings {
    /// The picture: size, background, tiles, supersampling.
    pub image: ImageSettings,
    /// Ray sampling: step, opacity reference step, early termination, skipping and
    /// the fast paths.
    pub sampling: Sampling,
    /// Lights, shadows, ambient colour and material.
    pub lighting: Lighting,
}

impl RenderSettings {
    /// The defaults with an image of `width × height` pixels.
    pub fn new(width: u32, height: u32) -> Self {
        RenderSettings {
            image: ImageSettings {
                width,
                height,
                ..ImageSettings::default()
            },
            ..RenderSettings::default()
        }
    }

    /// Checks every setting; the error names the field by its path, e.g.
    /// `sampling.step_voxels` or `lighting.lights[1].direction`.
    ///
    /// Field-dependent checks (bounds, spacing, samples per ray) are
    /// [`Sampling::world_step`]'s.
    pub fn validate(&self) -> Result<(), RenderError> {
        let im = &self.image;
        for (name, v) in [("image.width", im.width), ("image.height", im.height)] {
            if v == 0 {
                return Err(bad_setting(
                    name,
                    format!("must be ≥ 1, got {}×{}", im.width, im.height),
                ));
            }
        }
        if im.width as u64 * im.height as u64 > MAX_PIXELS {
            return Err(bad_setting(
                "image.width/height",
                format!("{}×{} exceeds {MAX_PIXELS} pixels", im.width, im.height),
            ));
        }
        if !im.background.to_array().iter().all(|c| (0.0..=1.0).contains(c)) {
            return Err(bad_setting(
                "image.background",
                format!("must be in [0, 1], got {}", im.background),
            ));
        }
        if im.tile_size == 0 {
            return Err(bad_setting("image.tile_size", "must be ≥ 1"));
        }
        if !(1..=MAX_SUPERSAMPLING).contains(&im.supersampling) {
            return Err(bad_setting(
                "image.supersampling",
                format!("must be 1 to {MAX_SUPERSAMPLING}, got {}", im.supersampling),
            ));
        }
        let rays = im.width as u64 * im.height as u64 * (im.supersampling as u64).pow(2);
        if rays > MAX_PIXELS * 4 {
            return Err(bad_setting(
                "image.supersampling",
                format!(
                    "{rays} rays ({}×{} pixels, {}² each) exceed {}",
                    im.width,
                    im.height,
                    im.supersampling,
                    MAX_PIXELS * 4
                ),
            ));
        }
        let s = &self.sampling;
        if !(s.step_voxels.is_finite() && s.step_voxels > 0.0) {
            return Err(bad_setting(
                "sampling.step_voxels",
                format!("must be finite and > 0, got {}", s.step_voxels),
            ));
        }
        if !(s.reference_step_voxels.is_finite() && s.reference_step_voxels > 0.0) {
            return Err(bad_setting(
                "sampling.reference_step_voxels",
                format!("must be finite and > 0, got {}", s.reference_step_voxels),
            ));
        }
        if s.early_termination_alpha.is_nan() {
            return Err(bad_setting("sampling.early_termination_alpha", "must not be NaN"));
        }
        let l = &self.lighting;
        for (i, light) in l.lights.iter().enumerate() {
            if !light.direction.is_finite() || light.direction == DVec3::ZERO {
                return Err(bad_setting(
                    format!("lighting.lights[{i}].direction"),
                    format!("must be finite and non-zero, got {}", light.direction),
                ));
            }
            check_finite_nonneg(format!("lighting.lights[{i}].colour"), &light.colour.to_array())?;
        }
        for (i, light) in l.point_lights.iter().enumerate() {
            light.validate(&format!("lighting.point_lights[{i}]"))?;
        }
        let sh = &l.shadows;
        for (k, c) in sh.casters.iter().enumerate() {
            let (n, list) = match *c {
                LightId::Directional(i) => (i, l.lights.len()),
                LightId::Point(i) => (i, l.point_lights.len()),
            };
            if n >= list {
                return Err(bad_setting(
                    format!("lighting.shadows.casters[{k}]"),
                    format!("names {c:?}, but there are only {list} such lights"),
                ));
            }
        }
        if !(sh.step_voxels.is_finite() && sh.step_voxels > 0.0) {
            return Err(bad_setting(
                "lighting.shadows.step_voxels",
                format!("must be finite and > 0, got {}", sh.step_voxels),
            ));
        }
        if !(0.0..1.0).contains(&sh.min_transmittance) {
            return Err(bad_setting(
                "lighting.shadows.min_transmittance",
                format!("must lie in [0, 1), got {}", sh.min_transmittance),
            ));
        }
        check_finite_nonneg("lighting.ambient_colour", &l.ambient_colour.to_array())?;
        let m = &l.material;
        for (name, v) in [
            ("ambient", m.ambient),
            ("diffuse", m.diffuse),
            ("specular", m.specular),
            ("shininess", m.shininess),
        ] {
            check_finite_nonneg(format!("lighting.material.{name}"), &[v])?;
        }
        Ok(())
    }
}

pub(crate) fn check_finite_nonneg(name: impl Into<String>, v: &[f32]) -> Result<(), RenderError> {
    if v.iter().all(|c| c.is_finite() && *c >= 0.0) {
        Ok(())
    } else {
        Err(bad_setting(name, format!("must be finite and ≥ 0, got {v:?}")))
    }
}
