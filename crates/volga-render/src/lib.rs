//! # volga-render — the embedded raycaster of volga
//!
//! Renders anything that implements [`volga_core::Field`]: cameras ([`Camera`]),
//! transfer functions ([`TransferFunction`]), opaque iso-surfaces, direct volume
//! rendering, maximum intensity projection and X-ray ([`Mode`]), driven by
//! [`render`]. The renderer samples the scene **only** through the `Field` trait
//! (`value`, `gradient`, `colour`, `bounds`, `value_range`, `sample_spacing`), so a
//! new representation becomes renderable by implementing that trait.
//!
//! ## Coordinate spaces and units
//! * **World space** is `f64` ([`glam::DVec3`]), the same space as `Field`
//!   positions. Rays are `origin + t·dir` with unit `dir`, so `t` is a world distance.
//! * **Image space** is pixels: `x` to the right, `y` **down**, pixel `(x, y)`'s
//!   centre at `(x + ½, y + ½)`; images are row-major.
//! * **Colour** is `f32` linear RGB; [`Image`] pixels are straight (not
//!   premultiplied) RGBA in \[0, 1\]; [`Image::to_rgba8`] applies a 1/2.2 gamma.
//!
//! ## Algorithms (survey references are to the volume graphics survey in
//! `shared/reference`)
//! * Shading: Blinn-Phong with the half vector, survey eq. 9, normals from the
//!   negated field gradient (density increases inwards), two-sided.
//! * Volume rendering: post-classification (survey eq. 15) and front-to-back
//!   compositing (survey eq. 13) with early ray termination and opacity correction
//!   for the ray step.
//! * Rays are clipped to `Field::bounds()` and sampled on a fixed lattice
//!   `t0 + (i + ½)·Δs` (iso mode: `t0 + i·Δs`, then bisection). Empty-space
//!   skipping over a coarse macro-cell grid built from `Field::value_range` keeps
//!   samples on that lattice, so it never changes the image.
//! * Tiles are rendered in parallel with rayon; each pixel is a pure function of its
//!   coordinates, so images are bit-identical for any thread count.
//!
//! ```
//! use glam::{DVec3, Vec3};
//! use volga_core::{Aabb, Field, NoProgress};
//! use volga_render::{render, Camera, Mode, Projection, RenderSettings, SurfaceColour};
//!
//! struct Ball;
//! impl Field for Ball {
//!     fn bounds(&self) -> Aabb { Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)) }
//!     fn value(&self, p: DVec3) -> f64 { (1.5 - p.length()).clamp(0.0, 1.0) }
//!     fn gradient_step(&self) -> DVec3 { DVec3::splat(0.05) }
//!     fn value_range(&self, _: &Aabb) -> (f64, f64) { (0.0, 1.0) }
//! }
//! let cam = Camera::look_at(DVec3::new(0.0, 0.0, 6.0), DVec3::ZERO, DVec3::Y,
//!     Projection::Perspective { fov_y_deg: 40.0 }).unwrap();
//! let settings = RenderSettings { width: 16, height: 16, ..Default::default() };
//! let mode = Mode::Iso { value: 0.5, colour: SurfaceColour::Constant(Vec3::ONE) };
//! let (image, stats) = render(&Ball, &cam, &mode, &settings, &NoProgress).unwrap();
//! assert_eq!(image.pixels.len(), 256);
//! assert_eq!(stats.rays, 256);
//! ```

mod camera;
mod error;
mod march;
mod render;
mod shading;
mod transfer;

pub use camera::{Camera, Projection, Ray};
pub use error::RenderError;
pub use march::{first_hit, Hit};
pub use render::{render, Image, Mode, RenderSettings, RenderStats, SurfaceColour};
pub(crate) use shading::Shader;
pub use shading::{Light, Material};
pub use transfer::TransferFunction;
