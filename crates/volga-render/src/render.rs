use glam::{Vec3, Vec4};
use rayon::prelude::*;
use volga_core::{Field, Progress};

use crate::error::bad_setting;
use crate::march::{MacroGrid, Tracer, ACTIVE, EMPTY_ABOVE, EMPTY_BELOW, MAX_STEPS_PER_RAY};
use crate::{Camera, Light, Material, RenderError, Shader, TransferFunction};

/// Colour `C_o` of an iso-surface.
#[derive(Clone, Debug, PartialEq)]
pub enum SurfaceColour {
    /// One linear RGB colour for the whole surface.
    Constant(Vec3),
    /// [`Field::colour`] at the hit; white where the field has none.
    FromField,
}

/// What a ray computes.
#[derive(Clone, Debug)]
pub enum Mode {
    /// Opaque iso-surface: the first crossing from below to above `value` (density
    /// increases inwards), refined by bisection, shaded with survey eq. 9.
    Iso { value: f64, colour: SurfaceColour },
    /// Direct volume rendering: post-classified (survey eq. 15) front-to-back
    /// compositing (survey eq. 13). With `colour_from_field` the RGB comes from
    /// [`Field::colour`] (white if none) and only alpha from the transfer function.
    Volume {
        transfer: TransferFunction,
        colour_from_field: bool,
    },
    /// Maximum intensity projection: grey = max value along the ray, clamped to
    /// \[0, 1\].
    Mip,
    /// Mean value along the ray inside the bounds, clamped to \[0, 1\].
    XRay,
}

/// Image size, sampling, lighting and acceleration parameters of [`render`].
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Ray step as a fraction of [`Field::sample_spacing`]; default 0.5.
    pub step_voxels: f64,
    /// Step (in sample spacings) the transfer function's opacities are defined
    /// for; default 1.0. Opacities are corrected to `α' = 1 − (1 − α)^(step/reference)`.
    pub reference_step_voxels: f64,
    /// Volume rays stop once accumulated alpha reaches this; default 0.99 (values
    /// above 1 disable early ray termination).
    pub early_termination_alpha: f32,
    /// Skip macro cells that cannot contribute (never changes the image); default on.
    pub empty_space_skipping: bool,
    /// Straight RGBA composited behind everything; default (0.05, 0.05, 0.08, 1).
    pub background: Vec4,
    /// Directional lights; empty means unlit, and then no gradient is evaluated.
    /// Default: one white light from direction (1, 1, 1).
    pub lights: Vec<Light>,
    /// Ambient colour `C_a` of survey eq. 9; default white.
    pub ambient_colour: Vec3,
    pub material: Material,
    /// Edge of the square pixel tiles rendered in parallel; default 16.
    pub tile_size: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 512,
            height: 512,
            step_voxels: 0.5,
            reference_step_voxels: 1.0,
            early_termination_alpha: 0.99,
            empty_space_skipping: true,
            background: Vec4::new(0.05, 0.05, 0.08, 1.0),
            lights: vec![Light {
                direction: glam::DVec3::ONE,
                colour: Vec3::ONE,
            }],
            ambient_colour: Vec3::ONE,
            material: Material::default(),
            tile_size: 16,
        }
    }
}

/// A rendered image: row-major, `y` down, straight (not premultiplied) linear RGBA
/// in \[0, 1\].
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec4>,
}

impl Image {
    /// Pixel at column `x`, row `y` (panics if outside the image).
    pub fn get(&self, x: u32, y: u32) -> Vec4 {
        assert!(x < self.width && y < self.height, "pixel ({x}, {y}) outside the image");
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// 8-bit RGBA, 4 bytes per pixel in the same order: gamma 1/2.2 applied to RGB
    /// (an sRGB approximation), alpha linear; rounded and clamped (NaN → 0).
    pub fn to_rgba8(&self) -> Vec<u8> {
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8; // NaN casts to 0
        let mut out = Vec::with_capacity(self.pixels.len() * 4);
        for p in &self.pixels {
            for c in [p.x, p.y, p.z] {
                out.push(q(c.max(0.0).powf(1.0 / 2.2)));
            }
            out.push(q(p.w));
        }
        out
    }
}

/// Work counters of one [`render`] call (integer sums: independent of scheduling).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RenderStats {
    /// Rays cast (one per pixel).
    pub rays: u64,
    /// [`Field::value`] evaluations along rays, including iso bisection steps.
    pub samples: u64,
    /// [`Field::gradient`] evaluations (0 when unlit).
    pub gradient_evaluations: u64,
    /// Volume rays stopped by early ray termination.
    pub rays_terminated_early: u64,
    /// Macro cells crossed without sampling by empty-space skipping.
    pub cells_skipped: u64,
}

impl std::ops::AddAssign for RenderStats {
    fn add_assign(&mut self, o: RenderStats) {
        self.rays += o.rays;
        self.samples += o.samples;
        self.gradient_evaluations += o.gradient_evaluations;
        self.rays_terminated_early += o.rays_terminated_early;
        self.cells_skipped += o.cells_skipped;
    }
}

/// Largest image rendered (pixels), so a typo cannot ask for terabytes.
const MAX_PIXELS: u64 = 1 << 28;

fn check_finite_nonneg(name: &'static str, v: &[f32]) -> Result<(), RenderError> {
    if v.iter().all(|c| c.is_finite() && *c >= 0.0) {
        Ok(())
    } else {
        Err(bad_setting(name, format!("must be finite and ≥ 0, got {v:?}")))
    }
}

fn validate(settings: &RenderSettings, mode: &Mode) -> Result<(), RenderError> {
    let s = settings;
    if s.width == 0 || s.height == 0 {
        return Err(bad_setting(
            "width/height",
            format!("must be ≥ 1, got {}×{}", s.width, s.height),
        ));
    }
    if s.width as u64 * s.height as u64 > MAX_PIXELS {
        return Err(bad_setting(
            "width/height",
            format!("{}×{} exceeds {MAX_PIXELS} pixels", s.width, s.height),
        ));
    }
    if !(s.step_voxels.is_finite() && s.step_voxels > 0.0) {
        return Err(bad_setting(
            "step_voxels",
            format!("must be finite and > 0, got {}", s.step_voxels),
        ));
    }
    if !(s.reference_step_voxels.is_finite() && s.reference_step_voxels > 0.0) {
        return Err(bad_setting(
            "reference_step_voxels",
            format!("must be finite and > 0, got {}", s.reference_step_voxels),
        ));
    }
    if s.early_termination_alpha.is_nan() {
        return Err(bad_setting("early_termination_alpha", "must not be NaN"));
    }
    if !s.background.to_array().iter().all(|c| (0.0..=1.0).contains(c)) {
        return Err(bad_setting(
            "background",
            format!("must be in [0, 1], got {}", s.background),
        ));
    }
    for l in &s.lights {
        if !l.direction.is_finite() || l.direction == glam::DVec3::ZERO {
            return Err(bad_setting(
                "lights.direction",
                format!("must be finite and non-zero, got {}", l.direction),
            ));
        }
        check_finite_nonneg("lights.colour", &l.colour.to_array())?;
    }
    check_finite_nonneg("ambient_colour", &s.ambient_colour.to_array())?;
    let m = &s.material;
    check_finite_nonneg("material", &[m.ambient, m.diffuse, m.specular, m.shininess])?;
    if s.tile_size == 0 {
        return Err(bad_setting("tile_size", "must be ≥ 1"));
    }
    if let Mode::Iso { value, colour } = mode {
        if !value.is_finite() {
            return Err(bad_setting(
                "mode.value",
                format!("iso value must be finite, got {value}"),
            ));
        }
        if let SurfaceColour::Constant(c) = colour {
            check_finite_nonneg("mode.colour", &c.to_array())?;
        }
    }
    Ok(())
}

/// Renders `field` as seen by `camera`.
///
/// One ray per pixel centre, clipped to `field.bounds()`; tiles of
/// `tile_size × tile_size` pixels are rendered in parallel with rayon, and each
/// pixel is a pure function of its coordinates, so the image is bit-identical for
/// any thread count. Progress: `start("render", tiles)`, `inc(1)` per tile,
/// `finish()`.
///
/// Errors: invalid settings or mode parameters, a field whose bounds are not
/// finite/non-empty or whose `sample_spacing()` is not finite and positive, or a
/// step so small that a ray would need more than 2²⁴ samples.
pub fn render<F: Field + ?Sized>(
    field: &F,
    camera: &Camera,
    mode: &Mode,
    settings: &RenderSettings,
    progress: &dyn Progress,
) -> Result<(Image, RenderStats), RenderError> {
    validate(settings, mode)?;
    let bounds = field.bounds();
    if !(bounds.min.is_finite() && bounds.max.is_finite()) || bounds.is_empty() {
        return Err(RenderError::BadFieldBounds {
            min: bounds.min.to_array(),
            max: bounds.max.to_array(),
        });
    }
    let spacing = field.sample_spacing();
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(RenderError::BadSampleSpacing(spacing));
    }
    let step = settings.step_voxels * spacing;
    let diagonal = bounds.size().length();
    let steps = diagonal / step;
    if !(step.is_finite() && step > 0.0 && steps.is_finite() && steps <= MAX_STEPS_PER_RAY) {
        return Err(bad_setting(
            "step_voxels",
            format!(
                "step of {step} world units needs more than {MAX_STEPS_PER_RAY} samples to cross the field bounds (diagonal {diagonal})"
            ),
        ));
    }

    let grid = match mode {
        _ if !settings.empty_space_skipping => None,
        Mode::XRay => None,
        Mode::Volume { transfer, .. } => Some(MacroGrid::build(field, bounds, spacing, |lo, hi| {
            if transfer.max_alpha(lo, hi) == 0.0 {
                EMPTY_BELOW
            } else {
                ACTIVE
            }
        })),
        Mode::Iso { value, .. } => Some(MacroGrid::build(field, bounds, spacing, |lo, hi| {
            if hi < *value {
                EMPTY_BELOW
            } else if lo > *value {
                EMPTY_ABOVE
            } else {
                ACTIVE
            }
        })),
        Mode::Mip => Some(MacroGrid::build(field, bounds, spacing, |_, _| ACTIVE)),
    };
    debug_assert!(grid.as_ref().is_none_or(|g| g.len() <= 64 * 64 * 64));

    let tracer = Tracer {
        field,
        bounds,
        step,
        tol: 1e-9 * spacing,
        alpha_exponent: settings.step_voxels / settings.reference_step_voxels,
        early_termination_alpha: settings.early_termination_alpha,
        background: settings.background,
        shader: Shader::new(&settings.lights, settings.ambient_colour, settings.material, spacing),
        grid,
    };

    let (w, h) = (settings.width, settings.height);
    let ts = settings.tile_size.min(w.max(h));
    let (tiles_x, tiles_y) = (w.div_ceil(ts), h.div_ceil(ts));
    let n_tiles = tiles_x as usize * tiles_y as usize;
    progress.start("render", n_tiles as u64);
    let tiles: Vec<(Vec<Vec4>, RenderStats)> = (0..n_tiles)
        .into_par_iter()
        .map(|tile| {
            let (x0, y0) = (
                (tile % tiles_x as usize) as u32 * ts,
                (tile / tiles_x as usize) as u32 * ts,
            );
            let (x1, y1) = ((x0 + ts).min(w), (y0 + ts).min(h));
            let mut stats = RenderStats::default();
            let mut px = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
            for y in y0..y1 {
                for x in x0..x1 {
                    let ray = camera.ray(x as f64, y as f64, w, h);
                    px.push(tracer.trace(mode, &ray, &mut stats));
                }
            }
            progress.inc(1);
            (px, stats)
        })
        .collect();
    progress.finish();

    let mut image = Image {
        width: w,
        height: h,
        pixels: vec![Vec4::ZERO; w as usize * h as usize],
    };
    let mut stats = RenderStats::default();
    for (tile, (px, s)) in tiles.into_iter().enumerate() {
        let (x0, y0) = (
            (tile % tiles_x as usize) as u32 * ts,
            (tile / tiles_x as usize) as u32 * ts,
        );
        let tw = ((x0 + ts).min(w) - x0) as usize;
        for (row, chunk) in px.chunks_exact(tw).enumerate() {
            let start = (y0 as usize + row) * w as usize + x0 as usize;
            image.pixels[start..start + tw].copy_from_slice(chunk);
        }
        stats += s;
    }
    Ok((image, stats))
}
