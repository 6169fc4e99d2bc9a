//! Solid textures and hypertextures (survey §17.6–17.7).
//!
//! * [`Perlin`]: gradient noise with the values of the `noise` crate 0.9 (same
//!   permutation tables, gradients, fade and scale; tested to 1e-12), computed faster
//!   along rows ([`Perlin::add_row`]); [`Fbm`] (the `noise` crate's `Fbm<Perlin>`),
//!   [`Turbulence`] (Σ|noise(2ⁱx)|/2ⁱ), [`fill`] for lattices (rayon over z slabs,
//!   identical for any thread count).
//! * [`Worley`]: exact F1/F2 cellular distances. [`SolidTexture`]: a [`Pattern`] through
//!   a [`ColourSpline`] (presets marble, wood, cells).
//! * [`HyperTexture`]: Perlin–Hoffert object density with inside / soft / outside
//!   regions, [`bias`], [`gain`] and [`Modulation`] chains, over any [`DistanceSource`]:
//!   an analytic shape ([`ShapeSource`]) or a sampled volume through the exact
//!   Euclidean distance transform ([`edt`], [`SampledDistance`]). It is a
//!   `volga_core::Field` whose `value_range` is exact about the regions, so noise is
//!   evaluated only in the soft band; [`HyperTexture::noise_evaluations`] counts it.
//!
//! Coordinates are world space `f64`; noise has unit lattice spacing times the
//! frequency given. Far from the origin (1e6) values stay finite: lattice coordinates
//! are wrapped to 8 bits as in the `noise` crate, and the fraction is computed in `f64`.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod counter;
pub mod edt;
mod error;
mod fractal;
mod hyper;
mod noise_field;
mod perlin;
mod sampled_distance;
mod solid;
mod worley;

pub use counter::Counter;
pub use error::TextureError;
pub use fractal::{fill, Fbm, Scaled, SolidNoise, Turbulence};
pub use hyper::{bias, gain, HyperTexture, Modulation, Region};
pub use noise_field::NoiseField;
pub use perlin::{fade, Perlin, RowHashes};
pub use sampled_distance::SampledDistance;
pub use solid::{ColourSpline, Pattern, SolidTexture};
/// The signed distance a hypertexture shapes, and a shape as one (from `volga-shapes`).
pub use volga_shapes::{DistanceSource, ShapeSource};
pub use worley::Worley;
