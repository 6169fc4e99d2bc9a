use glam::Vec4;
use rayon::prelude::*;
use volga_core::{Aabb, Field, FieldKind, Progress};

use crate::integrators::{clip, over_background, March, ModeJob};
use crate::light_volume::LightVolume;
use crate::macro_grid::MacroGrid;
use crate::shadow::ShadowParams;
use crate::{Camera, Integrator, Mode, PreIntegrated, RenderError, RenderSettings, Shader};

/// A rendered image: row-major, `y` down, straight (not premultiplied) linear RGBA
/// in \[0, 1\].
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Columns, in pixels.
    pub width: u32,
    /// Rows, in pixels.
    pub height: u32,
    /// `width × height` pixels, row by row from the top: pixel `(x, y)` is
    /// `pixels[y · width + x]`.
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

impl Image {
    /// 16-bit RGBA, 4 channels per pixel in the same order: the same gamma 1/2.2 on RGB
    /// and linear alpha as [`Image::to_rgba8`], scaled to 0–65535 (256 times finer
    /// steps for smooth gradients and post-processing).
    pub fn to_rgba16(&self) -> Vec<u16> {
        let q = |v: f32| (v.clamp(0.0, 1.0) * 65535.0).round() as u16; // NaN casts to 0
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
    /// Rays cast (`supersampling²` per pixel).
    pub rays: u64,
    /// Field values evaluated along rays ([`Field::values_along`] samples, including a
    /// run's samples read past an iso hit or an early termination, and the iso
    /// refinement's [`Field::value`] calls).
    pub samples: u64,
    /// [`Field::gradient`] evaluations (0 when unlit).
    pub gradient_evaluations: u64,
    /// Volume rays stopped by early ray termination.
    pub rays_terminated_early: u64,
    /// Empty-space skips: each run of macro cells crossed without sampling, jump over
    /// a block of them, or ray part outside the box of the cells that cannot be
    /// skipped counts once (a count of skips, not of cells).
    pub cells_skipped: u64,
    /// Shadow rays cast (one per shaded sample and light that casts shadows; 0 when
    /// no light does).
    pub shadow_rays: u64,
    /// Field values read along shadow rays.
    pub shadow_samples: u64,
    /// Transmittances read from light-space pre-pass grids instead of shadow rays
    /// ([`ShadowSettings::light_space`](crate::ShadowSettings::light_space)).
    pub shadow_lookups: u64,
}

impl std::ops::AddAssign for RenderStats {
    fn add_assign(&mut self, o: RenderStats) {
        self.rays += o.rays;
        self.samples += o.samples;
        self.gradient_evaluations += o.gradient_evaluations;
        self.rays_terminated_early += o.rays_terminated_early;
        self.cells_skipped += o.cells_skipped;
        self.shadow_rays += o.shadow_rays;
        self.shadow_samples += o.shadow_samples;
        self.shadow_lookups += o.shadow_lookups;
    }
}

/// Renders `field` as seen by `camera` in `mode`: dispatches once to the mode's
/// integrator and calls [`render_with`].
pub fn render<F: Field + ?Sized>(
    field: &F,
    camera: &Camera,
    mode: &Mode,
    settings: &RenderSettings,
    progress: &dyn Progress,
) -> Result<(Image, RenderStats), RenderError> {
    struct Job<'a, F: ?Sized> {
        field: &'a F,
        camera: &'a Camera,
        settings: &'a RenderSettings,
        progress: &'a dyn Progress,
    }
    impl<F: Field + ?Sized> ModeJob for Job<'_, F> {
        type Output = Result<(Image, RenderStats), RenderError>;
        fn run<I: Integrator>(self, integrator: &I) -> Self::Output {
            render_with(self.field, self.camera, integrator, self.settings, self.progress)
        }
    }
    mode.dispatch(Job {
        field,
        camera,
        settings,
        progress,
    })
}

/// Renders `field` as seen by `camera` with `integrator`: [`Renderer::new`] then
/// [`Renderer::render`] (to render several views of one field, keep the renderer).
///
/// Errors: those of [`Renderer::new`].
pub fn render_with<F: Field + ?Sized, I: Integrator>(
    field: &F,
    camera: &Camera,
    integrator: &I,
    settings: &RenderSettings,
    progress: &dyn Progress,
) -> Result<(Image, RenderStats), RenderError> {
    Ok(Renderer::new(field, integrator, settings)?.render(camera, progress))
}

/// A field, an integrator and settings prepared for rendering: validated, the field
/// prepared for sampling ([`Field::prepare`]: a sampled volume's brick atlas, the same
/// values bit for bit) and the empty-space skipping grid built (one pass over the
/// field's value ranges). Each [`Renderer::render`] then renders one view, so a
/// turntable or an interactive viewer prepares once per field and mode.
pub struct Renderer<'a, F: ?Sized, I> {
    integrator: &'a I,
    settings: &'a RenderSettings,
    bounds: Aabb,
    field: &'a F,
    /// What [`Field::prepare`] returned: sampled instead of `field` when present.
    prepared: Option<Box<dyn Field + 'a>>,
    /// What [`Field::pack`] returned when the packed path is allowed: sampled through
    /// `packet.rs` instead of `field` and `prepared`.
    packed: Option<crate::packed::PackedVolume>,
    constants: MarchConstants,
    shader: Shader,
    grid: Option<MacroGrid>,
    shadow: ShadowParams,
    preint: Option<PreIntegrated>,
    light_volumes: Vec<Option<LightVolume>>,
    /// The packed iso path's cell mask (built with the packed copy for iso modes).
    iso_mask: Option<crate::iso_packed::IsoCellMask>,
}

/// The scalar per-image constants of a [`March`].
#[derive(Clone, Copy)]
struct MarchConstants {
    inward: f64,
    kind: FieldKind,
    step: f64,
    tol: f64,
    alpha_exponent: f64,
    early_termination_alpha: f32,
}

impl<'a, F: Field + ?Sized, I: Integrator> Renderer<'a, F, I> {
    /// Validates and prepares. The field's [`kind`](Field::kind) is read once; the
    /// integrator is monomorphized with the field, so nothing is dispatched per sample
    /// (a prepared field is called through its vtable once per run of samples).
    ///
    /// Errors: invalid settings ([`RenderSettings::validate`]) or mode parameters
    /// ([`Integrator::validate`]), a field whose bounds are not finite/non-empty or
    /// whose `sample_spacing()` is not finite and positive, or a step so small that a
    /// ray would need more than 2²⁴ samples ([`Sampling::world_step`](crate::Sampling::world_step)).
    pub fn new(field: &'a F, integrator: &'a I, settings: &'a RenderSettings) -> Result<Self, RenderError> {
        settings.validate()?;
        integrator.validate()?;
        let bounds = field.bounds();
        let spacing = field.sample_spacing();
        let step = settings.sampling.world_step(&bounds, spacing)?;
        let kind = field.kind();

        let shadow = ShadowParams::new(settings, &bounds, spacing)?;
        let preint = settings
            .sampling
            .pre_integration
            .then(|| integrator.pre_integrate(settings, field.value_range(&bounds)))
            .flatten();

        let packed = crate::packet::packet_path_allowed(integrator, settings)
            .then(|| crate::packed::PackedVolume::of_field(field))
            .flatten();
        let prepared = if packed.is_none() && settings.sampling.prepare_field {
            field.prepare()
        } else {
            None
        };
        let grid = (settings.sampling.empty_space_skipping && integrator.skips_cells()).then(|| {
            let classify = |lo, hi| classify_cell(integrator, preint.as_ref(), lo, hi, kind);
            match &prepared {
                Some(p) => MacroGrid::build(&**p, bounds, spacing, classify),
                None => MacroGrid::build(field, bounds, spacing, classify),
            }
        });
        debug_assert!(grid.as_ref().is_none_or(|g| g.len() <= 64 * 64 * 64));
        let light_volumes = match &prepared {
            Some(p) => light_volumes(&**p, integrator, settings, &bounds, shadow, spacing),
            None => light_volumes(field, integrator, settings, &bounds, shadow, spacing),
        };

        let iso_mask = match (&packed, integrator.packed_iso_value()) {
            // Empty-space skipping off: the packed iso walk reads every cell.
            (Some(p), Some(iso)) if settings.sampling.empty_space_skipping => {
                Some(crate::iso_packed::IsoCellMask::build(p, kind.inward_sign(), iso))
            }
            _ => None,
        };
        let sampling = &settings.sampling;
        let lighting = &settings.lighting;
        Ok(Renderer {
            integrator,
            settings,
            bounds,
            field,
            prepared,
            packed,
            constants: MarchConstants {
                inward: kind.inward_sign(),
                kind,
                step,
                tol: 1e-9 * spacing,
                alpha_exponent: sampling.step_voxels / sampling.reference_step_voxels,
                early_termination_alpha: sampling.early_termination_alpha,
            },
            shader: Shader::from_lighting(lighting, spacing),
            grid,
            shadow,
            preint,
            light_volumes,
            iso_mask,
        })
    }

    /// Whether [`Field::prepare`] gave a faster field that this renderer samples.
    pub fn is_prepared(&self) -> bool {
        self.prepared.is_some()
    }

    /// Whether this renderer takes the packed fast path: the settings and the mode allow
    /// it ([`Sampling::packed_path`](crate::Sampling::packed_path), no shadows or point
    /// lights) and the field is a trilinear, central-difference reconstruction of voxels
    /// ([`Field::voxels`]) small enough to pack.
    pub fn is_packed(&self) -> bool {
        self.packed.is_some()
    }

    pub(crate) fn march<'r, G: Field + ?Sized>(&'r self, field: &'r G) -> March<'r, G> {
        self.march_packed(field, None)
    }

    /// [`Renderer::march`] over `field`, which samples `packed` when given (a
    /// `PackedField` over it, `packet.rs`).
    pub(crate) fn march_packed<'r, G: Field + ?Sized>(
        &'r self,
        field: &'r G,
        packed: Option<&'r crate::packed::PackedVolume>,
    ) -> March<'r, G> {
        let c = self.constants;
        March {
            field,
            inward: c.inward,
            kind: c.kind,
            step: c.step,
            tol: c.tol,
            alpha_exponent: c.alpha_exponent,
            early_termination_alpha: c.early_termination_alpha,
            shader: &self.shader,
            grid: self.grid.as_ref(),
            bounds: self.bounds,
            shadow: self.shadow,
            preint: self.preint.as_ref(),
            light_volumes: &self.light_volumes,
            iso_mask: self.iso_mask.as_ref(),
            iso_starts: None,
            packed,
        }
    }

    /// Field values read by the light-space shadow pre-pass when it was built (0 without).
    pub fn light_space_samples(&self) -> u64 {
        self.light_volumes.iter().flatten().map(|v| v.samples).sum()
    }

    /// Renders the view of `camera`.
    ///
    /// One ray per pixel centre (or `k × k` per pixel with
    /// [`ImageSettings::supersampling`](crate::ImageSettings::supersampling)), clipped
    /// to the field's bounds; tiles of
    /// `tile_size × tile_size` pixels are rendered in parallel with rayon, and each
    /// pixel is a pure function of its coordinates, so the image is bit-identical for
    /// any thread count. Progress: `start("render", tiles)`, `inc(1)` per tile,
    /// `finish()`.
    pub fn render(&self, camera: &Camera, progress: &dyn Progress) -> (Image, RenderStats) {
        if let Some(packed) = &self.packed {
            let field = crate::packet::PackedField {
                field: self.field,
                packed,
            };
            // The packed iso path's start map: part of the view, so built per frame.
            let image = &self.settings.image;
            let starts = self.iso_mask.as_ref().and_then(|mask| {
                crate::iso_packed::IsoStarts::build(
                    mask,
                    &packed.grid().transform,
                    &self.bounds,
                    camera,
                    image.width,
                    image.height,
                )
            });
            let mut march = self.march_packed(&field, Some(packed));
            march.iso_starts = starts.as_ref();
            return self.render_march(&march, camera, progress);
        }
        match &self.prepared {
            Some(p) => self.render_march(&self.march(&**p), camera, progress),
            None => self.render_march(&self.march(self.field), camera, progress),
        }
    }

    /// Pixels `(x, y)` in order (in batches of at most [`MAX_BATCH_RAYS`] rays), each one ray through its centre or the mean
    /// premultiplied colour of `k × k` rays through its sub-pixel centres (summed in a
    /// fixed order), over the background, appended to `out`. All their rays are
    /// integrated at once ([`Integrator::integrate_rays`]); each pixel is a function of
    /// its own rays alone. The one definition [`Renderer::render`] (a tile at a time) and
    /// [`Renderer::rerender_box`] (a row's touched pixels) share.
    pub(crate) fn trace_pixels<G: Field + ?Sized>(
        &self,
        march: &March<'_, G>,
        camera: &Camera,
        pixels: &[(u32, u32)],
        stats: &mut RenderStats,
        out: &mut Vec<Vec4>,
    ) {
        let k = self.settings.image.supersampling.max(1);
        // At most `MAX_BATCH_RAYS` rays at once (a row of a large supersampled image
        // would otherwise hold millions).
        let per_batch = (MAX_BATCH_RAYS / (k * k) as usize).max(1);
        if pixels.len() > per_batch {
            for chunk in pixels.chunks(per_batch) {
                self.trace_pixels(march, camera, chunk, stats, out);
            }
            return;
        }
        let background = self.settings.image.background;
        let (w, h) = (self.settings.image.width, self.settings.image.height);
        let mut rays = Vec::with_capacity(pixels.len() * (k * k) as usize);
        for &(x, y) in pixels {
            if k == 1 {
                rays.push(camera.ray(x as f64, y as f64, w, h));
                continue;
            }
            for j in 0..k {
                for i in 0..k {
                    let (sx, sy) = sub_pixel(x, y, i, j, k);
                    rays.push(camera.ray(sx, sy, w, h));
                }
            }
        }
        stats.rays += rays.len() as u64;
        let intervals: Vec<Option<(f64, f64)>> = rays.iter().map(|ray| clip(&self.bounds, ray)).collect();
        let mut colours = vec![(glam::Vec3::ZERO, 0.0f32); rays.len()];
        self.integrator
            .integrate_rays(march, &rays, &intervals, stats, &mut colours);
        if k == 1 {
            out.extend(colours.iter().map(|&(c, a)| over_background(background, c, a)));
            return;
        }
        let n = (k * k) as f32;
        for samples in colours.chunks_exact((k * k) as usize) {
            let (mut c_sum, mut a_sum) = (glam::Vec3::ZERO, 0.0f32);
            for &(c, a) in samples {
                if c.is_finite() && a.is_finite() {
                    c_sum += c;
                    a_sum += a.clamp(0.0, 1.0);
                }
            }
            out.push(over_background(background, c_sum / n, a_sum / n));
        }
    }

    fn render_march<G: Field + ?Sized>(
        &self,
        march: &March<'_, G>,
        camera: &Camera,
        progress: &dyn Progress,
    ) -> (Image, RenderStats) {
        let (w, h) = (self.settings.image.width, self.settings.image.height);

        let ts = self.settings.image.tile_size.min(w.max(h));
        let (tiles_x, tiles_y) = (w.div_ceil(ts), h.div_ceil(ts));
        let n_tiles = tiles_x as usize * tiles_y as usize;
        progress.start("render", n_tiles as u64);
        // One job per tile (`with_max_len(1)`): rayon's adaptive split otherwise hands a
        // thread a run of tiles it works through alone, and where the costly tiles
        // bunch up (an object in the middle of the image) the other thread idled: 10 %
        // of the bunny's DVR frame on two threads (docs/BENCHMARKS.md).
        let tiles: Vec<(Vec<Vec4>, RenderStats)> = (0..n_tiles)
            .into_par_iter()
            .with_max_len(1)
            .map(|tile| {
                let (x0, y0) = (
                    (tile % tiles_x as usize) as u32 * ts,
                    (tile / tiles_x as usize) as u32 * ts,
                );
                let (x1, y1) = ((x0 + ts).min(w), (y0 + ts).min(h));
                let mut stats = RenderStats::default();
                let mut px = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
                if march.iso_tile_misses(camera, (x0, y0, x1, y1), (w, h)) {
                    // Every ray of the tile misses (the packed iso path's start map):
                    // each pixel is what `trace_pixels` gives a ray that meets nothing.
                    let k = self.settings.image.supersampling.max(1) as u64;
                    stats.rays += ((x1 - x0) * (y1 - y0)) as u64 * k * k;
                    let bg = over_background(self.settings.image.background, glam::Vec3::ZERO, 0.0);
                    px.resize(((x1 - x0) * (y1 - y0)) as usize, bg);
                } else {
                    let pixels: Vec<(u32, u32)> = (y0..y1).flat_map(|y| (x0..x1).map(move |x| (x, y))).collect();
                    self.trace_pixels(march, camera, &pixels, &mut stats, &mut px);
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
        (image, stats)
    }
}

/// Rays [`Renderer::trace_pixels`] integrates at once: a 16×16 tile of 4×4 supersampled
/// pixels.
const MAX_BATCH_RAYS: usize = 4096;

/// The light-space transmittance grids of `settings`' shadow-casting directional lights
/// (per light, directional first then point: `None` where a light has none), built only
/// when [`ShadowSettings::light_space`](crate::ShadowSettings::light_space) is on and the
/// integrator's shadows are its classification's transmittance.
fn light_volumes<G: Field + ?Sized, I: Integrator>(
    field: &G,
    integrator: &I,
    settings: &RenderSettings,
    bounds: &Aabb,
    shadow: ShadowParams,
    spacing: f64,
) -> Vec<Option<LightVolume>> {
    let l = &settings.lighting;
    let n = l.lights.len() + l.point_lights.len();
    let mut out: Vec<Option<LightVolume>> = (0..n).map(|_| None).collect();
    if !l.shadows.light_space || integrator.shadow_opacity(0.0).is_none() {
        return out;
    }
    let reference = settings.sampling.reference_step_voxels * spacing;
    for c in &l.shadows.casters {
        if let crate::LightId::Directional(i) = *c {
            if let Some(light) = l.lights.get(i) {
                let dir = light.direction.normalize_or_zero();
                if dir != glam::DVec3::ZERO && out[i].is_none() {
                    let alpha = |v: f64| integrator.shadow_opacity(v).unwrap_or(0.0);
                    out[i] = Some(LightVolume::build(field, bounds, dir, shadow.step, reference, alpha));
                }
            }
        }
    }
    out
}

/// The skip class of a macro cell: the integrator's, made `Active` where a
/// pre-integrated segment between values of the cell's range may be visible.
pub(crate) fn classify_cell<I: Integrator>(
    integrator: &I,
    preint: Option<&PreIntegrated>,
    lo: f64,
    hi: f64,
    kind: FieldKind,
) -> crate::CellClass {
    let class = integrator.classify_cell(lo, hi, kind);
    match preint {
        Some(t) if class == crate::CellClass::Outside && t.max_alpha(lo, hi) > 0.0 => crate::CellClass::Active,
        _ => class,
    }
}

/// Image coordinates of sub-pixel `(i, j)` of pixel `(x, y)` with `k × k` samples.
#[inline]
pub(crate) fn sub_pixel(x: u32, y: u32, i: u32, j: u32, k: u32) -> (f64, f64) {
    (
        x as f64 - 0.5 + (i as f64 + 0.5) / k as f64,
        y as f64 - 0.5 + (j as f64 + 0.5) / k as f64,
    )
}

// Localized re-render (`Renderer::rerender_box`), in its own file.
#[path = "region.rs"]
mod region;
