//! Perlin–Hoffert hypertextures (survey §17.7): an object density `D(x)` with an inside
//! region (density 1), an outside region (0) and a soft region between them where a
//! chain of density modulation functions (noise, turbulence, bias, gain) shapes the
//! density. Noise is evaluated in the soft region only, and the soft region is known
//! per box ([`HyperTexture::region`]), so a renderer or baker skips the rest.

use glam::{DVec3, Vec3};
use volga_core::{Aabb, Field};
use volga_shapes::DistanceSource;

use crate::{Counter, SolidNoise, TextureError};

/// Perlin's bias: `t^(ln b / ln ½)`, so `bias(b, ½) = b` and the end points stay put.
/// Inputs are clamped to \[0, 1\]. Documented values where the power law is undefined or
/// degenerate: `bias(b, 0) = 0` and `bias(b, 1) = 1` for every `b`; for `0 < t < 1`,
/// `bias(0, t) = 0` and `bias(1, t) = 1`. NaN inputs give 0. Always finite.
pub fn bias(b: f64, t: f64) -> f64 {
    let (b, t) = (clamp01(b), clamp01(t));
    if t <= 0.0 {
        0.0
    } else if t >= 1.0 {
        1.0
    } else if b <= 0.0 {
        0.0
    } else if b >= 1.0 {
        1.0
    } else {
        t.powf(b.ln() / 0.5f64.ln())
    }
}

/// Perlin's gain: `bias(1 − g, 2t)/2` below ½, `1 − bias(1 − g, 2 − 2t)/2` above, so
/// `gain(g, 0) = 0`, `gain(g, ½) = ½`, `gain(g, 1) = 1` for every `g`, and `gain(½, t) = t`.
/// From [`bias`]'s end values: for `0 < t < ½`, `gain(0, t) = ½` and `gain(1, t) = 0`; for
/// `½ < t < 1`, `gain(0, t) = ½` and `gain(1, t) = 1`. Always finite.
pub fn gain(g: f64, t: f64) -> f64 {
    let (g, t) = (clamp01(g), clamp01(t));
    if t < 0.5 {
        bias(1.0 - g, 2.0 * t) / 2.0
    } else if t > 0.5 {
        1.0 - bias(1.0 - g, 2.0 - 2.0 * t) / 2.0
    } else {
        0.5
    }
}

fn clamp01(x: f64) -> f64 {
    if x.is_nan() {
        0.0
    } else {
        x.clamp(0.0, 1.0)
    }
}

/// One step of a modulation chain.
#[derive(Debug)]
pub enum Modulation {
    /// Moves the surface: `d ← d − amplitude · noise(p ⊙ stretch)` (noisy sphere;
    /// fire with turbulence stretched along the flame).
    Displace {
        /// The noise.
        noise: Box<dyn SolidNoise>,
        /// World units the surface moves per unit of noise.
        amplitude: f64,
        /// Per-axis scale of the point the noise is evaluated at.
        stretch: DVec3,
    },
    /// Fur: strands along the surface normals: `t ← t · bias(b, ½ + ½·noise(q))` with
    /// `q = p − d(p)·∇d/‖∇d‖` the point's foot on the surface (central differences of
    /// the distance), so the noise is constant along each normal line; `b` the strand
    /// sharpness.
    Fur {
        /// The noise, evaluated on the surface.
        noise: Box<dyn SolidNoise>,
        /// The bias `b` of the strands (in \[0, 1\]).
        sharpness: f64,
    },
    /// `t ← t · (1 + amplitude · noise(p))`, clamped to \[0, 1\].
    Scale {
        /// The noise.
        noise: Box<dyn SolidNoise>,
        /// How much a unit of noise scales the density.
        amplitude: f64,
    },
    /// `t ← bias(b, t)`.
    Bias(f64),
    /// `t ← gain(g, t)`.
    Gain(f64),
}

impl Modulation {
    /// How far this step can move the surface (world units).
    fn displacement_bound(&self) -> f64 {
        match self {
            Modulation::Displace { noise, amplitude, .. } => {
                let (lo, hi) = noise.range();
                amplitude.abs() * lo.abs().max(hi.abs())
            }
            _ => 0.0,
        }
    }
}

/// Where a box lies relative to the soft region.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Region {
    /// Density 1 throughout (`d ≤ −reach`).
    Inside,
    /// Density 0 throughout (`d ≥ reach`).
    Outside,
    /// The box may meet the soft band: densities anywhere in \[0, 1\].
    Soft,
}

/// A hypertexture: `D(x)` from a signed distance with a soft band of half-width
/// `soft_width` (density `½ − d/(2·soft_width)` before modulation), then the chain.
/// Inside `d ≤ −(soft_width + M)` the density is 1, outside `d ≥ soft_width + M` it is 0,
/// where `M` bounds the chain's surface displacement.
pub struct HyperTexture {
    distance: Box<dyn DistanceSource + Send>,
    soft_width: f64,
    reach: f64,
    chain: Vec<Modulation>,
    colour: Option<Vec3>,
    step: f64,
    noise_evaluations: Counter,
    samples: Counter,
}

impl std::fmt::Debug for HyperTexture {
    /// The distance source as its bounds and exactness (a trait object has no `Debug`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HyperTexture")
            .field(
                "distance",
                &format_args!(
                    "DistanceSource {{ bounds: {:?}, exact: {} }}",
                    self.distance.bounds(),
                    self.distance.is_exact()
                ),
            )
            .field("soft_width", &self.soft_width)
            .field("reach", &self.reach)
            .field("chain", &self.chain)
            .field("colour", &self.colour)
            .field("step", &self.step)
            .field("noise_evaluations", &self.noise_evaluations)
            .field("samples", &self.samples)
            .finish()
    }
}

impl HyperTexture {
    /// The hypertexture of `distance` with a soft band of half-width `soft_width` shaped
    /// by `chain`; `sample_spacing` is the length scale rays and gradients step by. Both
    /// are world units and must be finite and > 0: an argument that is not is refused,
    /// named with its value ([`TextureError::SoftWidth`], [`TextureError::SampleSpacing`]).
    pub fn new(
        distance: Box<dyn DistanceSource + Send>,
        soft_width: f64,
        chain: Vec<Modulation>,
        sample_spacing: f64,
    ) -> Result<Self, TextureError> {
        if !(soft_width.is_finite() && soft_width > 0.0) {
            return Err(TextureError::SoftWidth(soft_width));
        }
        if !(sample_spacing.is_finite() && sample_spacing > 0.0) {
            return Err(TextureError::SampleSpacing(sample_spacing));
        }
        let displacement: f64 = chain.iter().map(Modulation::displacement_bound).sum();
        Ok(HyperTexture {
            distance,
            soft_width,
            reach: soft_width + displacement,
            chain,
            colour: None,
            step: sample_spacing,
            noise_evaluations: Counter::new(),
            samples: Counter::new(),
        })
    }

    /// The same hypertexture with one colour everywhere (linear RGB).
    pub fn with_colour(mut self, colour: Vec3) -> Self {
        self.colour = Some(colour);
        self
    }

    /// The half-width of the band where density is not 0 or 1 (soft width plus the
    /// chain's displacement bound).
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// Noise evaluations so far (one per octave of each noise call).
    pub fn noise_evaluations(&self) -> u64 {
        self.noise_evaluations.get()
    }

    /// Density samples so far.
    pub fn samples(&self) -> u64 {
        self.samples.get()
    }

    /// The box's region: all inside, all outside, or touching the soft band.
    pub fn region(&self, world_box: &Aabb) -> Region {
        let (lo, hi) = self.distance.range(world_box);
        if lo >= self.reach {
            Region::Outside
        } else if hi <= -self.reach {
            Region::Inside
        } else {
            Region::Soft
        }
    }

    fn cost(noise: &dyn SolidNoise) -> u64 {
        noise.octave_count() as u64
    }

    /// The unit gradient of the distance by central differences of `step` (zero where
    /// it vanishes).
    fn normal(&self, p: DVec3) -> DVec3 {
        let h = self.step;
        let d = |e: DVec3| self.distance.distance(p + e * h) - self.distance.distance(p - e * h);
        DVec3::new(d(DVec3::X), d(DVec3::Y), d(DVec3::Z)).normalize_or_zero()
    }

    /// The modulated density at a point.
    pub fn density(&self, p: DVec3) -> f64 {
        self.samples.add(1);
        let d0 = self.distance.distance(p);
        if d0 >= self.reach {
            return 0.0;
        }
        if d0 <= -self.reach {
            return 1.0;
        }
        let mut d = d0;
        let mut evaluations = 0;
        for m in &self.chain {
            if let Modulation::Displace {
                noise,
                amplitude,
                stretch,
            } = m
            {
                d -= amplitude * noise.value(p * *stretch);
                evaluations += Self::cost(noise.as_ref());
            }
        }
        let mut t = clamp01(0.5 - d / (2.0 * self.soft_width));
        for m in &self.chain {
            t = match m {
                Modulation::Displace { .. } => t,
                Modulation::Fur { noise, sharpness } => {
                    if t <= 0.0 {
                        continue;
                    }
                    let foot = p - self.normal(p) * d0;
                    evaluations += Self::cost(noise.as_ref());
                    t * bias(*sharpness, 0.5 + 0.5 * noise.value(foot))
                }
                Modulation::Scale { noise, amplitude } => {
                    evaluations += Self::cost(noise.as_ref());
                    clamp01(t * (1.0 + amplitude * noise.value(p)))
                }
                Modulation::Bias(b) => bias(*b, t),
                Modulation::Gain(g) => gain(*g, t),
            };
        }
        self.noise_evaluations.add(evaluations);
        t
    }
}

impl Field for HyperTexture {
    fn bounds(&self) -> Aabb {
        self.distance.bounds().expanded(DVec3::splat(self.reach))
    }
    fn value(&self, world_pos: DVec3) -> f64 {
        self.density(world_pos)
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.step)
    }
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        match self.region(world_box) {
            Region::Inside => (1.0, 1.0),
            Region::Outside => (0.0, 0.0),
            Region::Soft => (0.0, 1.0),
        }
    }
    fn has_colour(&self) -> bool {
        self.colour.is_some()
    }
    fn colour(&self, _world_pos: DVec3) -> Option<Vec3> {
        self.colour
    }
}
