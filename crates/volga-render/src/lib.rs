//! # volga-render — the embedded raycaster of volga
//!
//! Renders anything that implements [`volga_core::Field`]: cameras ([`Camera`]),
//! one integrator per render mode ([`Iso`], [`Volume`], [`Mip`], [`XRay`], gathered
//! in [`Mode`]), grouped [`RenderSettings`] ([`ImageSettings`], [`Sampling`],
//! [`Lighting`]), driven by [`render`]. The renderer samples the scene **only**
//! through the `Field` trait (`kind`, `value`, `gradient`, `colour`, `bounds`,
//! `value_range`, `sample_spacing`), so a new representation becomes renderable by
//! implementing that trait.
//!
//! ## Coordinate spaces and units
//! * **World space** is `f64` ([`glam::DVec3`]), the same space as `Field`
//!   positions. Rays are `origin + t·dir` with unit `dir`, so `t` is a world distance.
//! * **Image space** is pixels: `x` to the right, `y` **down**, pixel `(x, y)`'s
//!   centre at `(x + ½, y + ½)`; images are row-major.
//! * **Colour** is `f32` linear RGB; [`Image`] pixels are straight (not
//!   premultiplied) RGBA in \[0, 1\]; [`Image::to_rgba8`] applies a 1/2.2 gamma.
//!
//! ## The renderer's axes
//! * **What the value means** — [`volga_core::FieldKind`], read once per image: a
//!   density (or binary occupancy) is inside where `≥ iso` with outward normal `−∇`,
//!   a signed distance inside where `≤ iso` with outward normal `+∇`. Iso-surfaces
//!   and shading follow the kind through a sign decided once, never a call per sample.
//! * **What a ray computes** — an [`Integrator`] per mode, one file each under
//!   `src/integrators/`. Each owns its parameters' validation
//!   ([`Integrator::validate`]), its macro-cell skip classification
//!   ([`Integrator::classify_cell`], returning a [`CellClass`]), its per-ray
//!   integration ([`Integrator::integrate`], generic over the field so the sample
//!   loop is monomorphized) and the [`Effects`] it needs given the settings
//!   (gradients, colour, shadows, early termination, skipping —
//!   [`Integrator::effects`]), so planners ask the mode instead of matching on it.
//!   [`render`] dispatches a [`Mode`] to its integrator once per image;
//!   [`render_with`] takes any integrator directly; a [`Renderer`] prepares a field
//!   and an integrator once (validation, the skipping grid) for many views.
//! * **How samples become colour** (volume rendering) — a [`Classifier`] slot: today
//!   the 1D [`TransferFunction`], post-classified, or, with
//!   [`Sampling::pre_integration`], pre-integrated ([`PreIntegrated`]: a 2D table over
//!   the values at both ends of a ray segment, built once per image for its step by
//!   [`Integrator::pre_integrate`]); any [`Classify`] implementation plugs in without
//!   touching the compositing loop.
//! * **Which effects run** — only those the settings ask for: point lights
//!   ([`PointLight`], optionally attenuated) beside directional ones, and volumetric
//!   shadows (survey eq. 10, `src/shadow.rs`) only for the lights
//!   [`ShadowSettings::casters`] names, with a shadow step as the quality knob, and
//!   for directional lights in volume rendering a light-space pre-pass
//!   ([`ShadowSettings::light_space`], `src/light_volume.rs`: one transmittance grid per
//!   light swept once per image, read trilinearly per sample). With
//!   directional lights only and no shadows, samples take the plain shading path
//!   ([`Lighting::is_plain`]); [`RenderStats::shadow_rays`] and
//!   [`RenderStats::shadow_samples`] count what shadows cost (0 when no light casts them).
//! * **Settings** — [`RenderSettings`] groups [`ImageSettings`] (size, background,
//!   tiles), [`Sampling`] (step, reference step, early termination, skipping) and
//!   [`Lighting`] (lights, ambient colour, material), validated in one place
//!   ([`RenderSettings::validate`], errors name the field path such as
//!   `sampling.step_voxels`); the field-dependent "at most 2²⁴ samples per ray" check
//!   is [`Sampling::world_step`], callable before any field exists.
//!
//! ## Algorithms (survey references are to the volume graphics survey in
//! `shared/reference`)
//! * Shading: Blinn-Phong with the half vector, survey eq. 9, normals from the
//!   field gradient oriented outwards by the field's kind, two-sided; a point light's
//!   direction and attenuation are taken per sample.
//! * Shadows (survey eq. 10): volume rendering multiplies a light's colour by the
//!   transmittance along the shadow ray, the product of `(1 − α)^(h/Δs_ref)` of the
//!   same classification at shadow step `h`; an iso-surface is shadowed where the
//!   shadow ray meets its inside. Shadow rays walk the same macro-cell grid (so
//!   skipping never changes a shadow) and stop below
//!   [`ShadowSettings::min_transmittance`].
//! * Pre-integration (Engel et al.; survey §7): with [`Sampling::pre_integration`] each
//!   sample composites the segment from the previous sample, looked up bilinearly in
//!   the table; skipped runs keep their end samples so skipping stays exact.
//! * Volume rendering: post-classification (survey eq. 15) and front-to-back
//!   compositing (survey eq. 13) with early ray termination and opacity correction
//!   for the ray step.
//! * Rays are clipped to `Field::bounds()` and sampled on a fixed lattice
//!   `t0 + (i + ½)·Δs` (iso mode: `t0 + i·Δs`, then the bracket of the first crossing
//!   is refined by regula falsi safeguarded by bisection). Samples are read in runs
//!   through [`Field::values_along`](volga_core::Field::values_along) — one run per
//!   macro cell, at most 32 samples — so a sampled volume is read brick by brick, not
//!   looked up per sample, and volume rendering reads the gradients of a run's
//!   visible samples in one [`Field::gradients_at`](volga_core::Field::gradients_at)
//!   call. Empty-space skipping walks a coarse macro-cell grid built from
//!   `Field::value_range` with a 3D DDA; skipped samples are whole lattice indices and
//!   every value is a function of its index alone, so skipping never changes the image.
//! * **Preparation**: [`Renderer::new`] asks the field for a prepared equivalent
//!   ([`Field::prepare`](volga_core::Field::prepare), default `None`) and samples it
//!   instead; a sampled volume returns itself over a
//!   [`BrickAtlas`](volga_core::BrickAtlas) (padded 16³ tiles behind a flat table: one
//!   table read and eight loads per trilinear sample, one 4×4×4 copy per gradient),
//!   the same bits as the volume ([`Sampling::prepare_field`] turns it off; a test
//!   checks every mode draws the same image either way). Shading normalizes the
//!   Blinn-Phong half vectors once per ray.
//! * **The packed fast path** (`src/packet.rs`): for shaded DVR with a 1D transfer
//!   function (at most 8 control points, colour from it) of a field that is a trilinear,
//!   central-difference reconstruction of voxels ([`Field::voxels`](volga_core::Field::voxels):
//!   [`volga_core::Sampled`] volumes), the renderer packs a copy (`packed.rs`) — per voxel
//!   the density and its central-difference gradient, four `f32` in padded 16³ tiles),
//!   [`Renderer::new`] packs the field once instead of preparing its atlas, and each
//!   ray's samples are taken eight at a time: value **and** gradient from one 8-corner
//!   fetch (seven 4-wide lerps instead of a 4×4×4 stencil and four reconstructions),
//!   then classification, opacity correction and Blinn-Phong in 8 `f32` lanes with
//!   per-ray constants, compiled for AVX2+FMA when the CPU has them (a baseline build of
//!   the same code otherwise), and each packet composited at once (a product scan of
//!   `1 − α` over its lanes; packets start at multiples of eight on the lattice). A ray
//!   is first clipped to the box of the macro cells that are not skippable, and its
//!   walk answers once per run of like cells (`sample_walk.rs`). The
//!   lattice, skipping and early termination are the general loop's; each lane is a
//!   function of its sample index alone and invisible lanes add exactly nothing, so
//!   skipping never changes the image and any thread count gives the same bits. Images equal the general path's within 1/255 per channel (tests: 7e-7 seen).
//!   One predicate decides it (`packet_path_allowed`: [`Sampling::packed_path`], the
//!   integrator's [`Integrator::packed_path`], no shadows, ≤ 8 lights); iso-surfaces of
//!   such volumes have their own packed path (`iso_packed.rs`: exact crossings cell by
//!   cell); everything else — projections, other filters and gradient methods, analytic
//!   fields, CVG trees, octrees, ADFs — takes the general path.
//! * Reconstruction and gradients are the field's: [`volga_core::Sampled`] offers
//!   nearest, trilinear, Catmull–Rom and cubic B-spline filters
//!   ([`volga_core::Filter`]) with central-difference or analytic gradients
//!   ([`volga_core::GradientMethod`]); the renderer does not know which.
//! * Anti-aliasing: [`ImageSettings::supersampling`] `k` casts `k × k` rays per pixel
//!   through a regular grid of sub-pixel centres and averages their premultiplied
//!   colours (the box-filtered image of `k` times the resolution).
//! * Tiles are rendered in parallel with rayon; each pixel is a pure function of its
//!   coordinates, so images are bit-identical for any thread count.
//!
//! ## How to add a render mode
//! 1. Write `src/integrators/<mode>.rs`: a type with the mode's parameters and an
//!    `impl Integrator` (`name`, `validate`, `effects`, `classify_cell` — or
//!    `skips_cells() == false` — and `integrate`, built from the crate's marching
//!    helpers in `march.rs`: sample lattices, `march_iso`, macro-grid lookups).
//! 2. Add one line `<mode>::<Type>,`, under a `///` line that documents the
//!    `Mode::<Type>` variant, to the `modes!` list at the end of
//!    `src/integrators/mod.rs`: it declares the module, re-exports the type and adds
//!    the `Mode::<Type>` variant with its dispatch.
//! 3. For scene files, map a scene mode to it in `volga-scene`'s validation (the
//!    planner needs nothing: it asks [`Integrator::effects`]).
//!
//! ```
//! use glam::{DVec3, Vec3};
//! use volga_core::{Aabb, Field, FieldKind, NoProgress};
//! use volga_render::{render, Camera, Integrator, Iso, Mode, Projection, RenderSettings, SurfaceColour};
//!
//! /// A ball of radius 1.5 as a signed distance: negative inside.
//! struct Ball;
//! impl Field for Ball {
//!     fn kind(&self) -> FieldKind { FieldKind::SignedDistance }
//!     fn bounds(&self) -> Aabb { Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)) }
//!     fn value(&self, p: DVec3) -> f64 { p.length() - 1.5 }
//!     fn gradient_step(&self) -> DVec3 { DVec3::splat(0.05) }
//!     fn value_range(&self, _: &Aabb) -> (f64, f64) { (f64::NEG_INFINITY, f64::INFINITY) }
//! }
//! let cam = Camera::look_at(DVec3::new(0.0, 0.0, 6.0), DVec3::ZERO, DVec3::Y,
//!     Projection::Perspective { fov_y_deg: 40.0 }).unwrap();
//! let settings = RenderSettings::new(16, 16);
//! let mode = Mode::Iso(Iso { value: 0.0, colour: SurfaceColour::Constant(Vec3::ONE) });
//! assert!(mode.integrator().effects(&settings).gradients.enabled); // lit by default
//! let (image, stats) = render(&Ball, &cam, &mode, &settings, &NoProgress).unwrap();
//! assert_eq!(image.pixels.len(), 256);
//! assert_eq!(stats.rays, 256);
//! assert_ne!(image.get(8, 8), settings.image.background); // the centre ray hits the ball
//! assert_eq!(image.get(0, 0), settings.image.background); // a corner ray misses
//! ```
#![warn(missing_docs)]

mod camera;
mod classify;
mod error;
mod integrators;
mod iso_packed;
mod light_volume;
mod macro_grid;
mod march;
mod packed;
mod packet;
mod preint;
mod render;
mod sample_walk;
mod settings;
mod shading;
mod shadow;
#[cfg(test)]
mod test_cpu;
mod transfer;

pub use camera::{Camera, Projection, Ray};
pub use classify::{Classifier, Classify, ClassifySample};
pub use error::RenderError;
// The integrators and every registered mode's types (`Iso`, `SurfaceColour`, `Volume`, `Mip`, `XRay`).
pub use integrators::*;
pub use macro_grid::CellClass;
pub use march::{first_hit, Hit};
pub use preint::{PreIntegrated, PRE_INTEGRATION_TABLE_SIZE};
pub use render::{render, render_with, Image, RenderStats, Renderer};
pub use settings::{
    ImageSettings, Lighting, RenderSettings, Sampling, ShadowSettings, MAX_PIXELS, MAX_SAMPLES_PER_RAY,
    MAX_SUPERSAMPLING,
};
pub(crate) use shading::Shader;
pub use shading::{Attenuation, Light, LightId, Material, PointLight};
pub use transfer::TransferFunction;
