//! A solid noise as a density field: `clamp(offset + gain · noise(p), 0, 1)` over a box,
//! counting its noise evaluations.

use glam::DVec3;
use volga_core::{Aabb, Field};

use crate::{Counter, SolidNoise};

/// Noise as a density in \[0, 1\] inside `bounds` (0 outside).
#[derive(Debug)]
pub struct NoiseField {
    noise: Box<dyn SolidNoise>,
    offset: f64,
    gain: f64,
    bounds: Aabb,
    step: f64,
    noise_evaluations: Counter,
}

impl NoiseField {
    /// `clamp(offset + gain · noise(p), 0, 1)` inside `bounds`; `sample_spacing` (world
    /// units) is the central-difference step of its gradient.
    pub fn new(noise: Box<dyn SolidNoise>, offset: f64, gain: f64, bounds: Aabb, sample_spacing: f64) -> Self {
        NoiseField {
            noise,
            offset,
            gain,
            bounds,
            step: sample_spacing,
            noise_evaluations: Counter::new(),
        }
    }

    /// Perlin evaluations so far (octaves count).
    pub fn noise_evaluations(&self) -> u64 {
        self.noise_evaluations.get()
    }
}

impl Field for NoiseField {
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn value(&self, world_pos: DVec3) -> f64 {
        self.noise_evaluations.add(self.noise.octave_count() as u64);
        (self.offset + self.gain * self.noise.value(world_pos)).clamp(0.0, 1.0)
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.step)
    }
    fn value_range(&self, _world_box: &Aabb) -> (f64, f64) {
        let (lo, hi) = self.noise.range();
        let (a, b) = (self.offset + self.gain * lo, self.offset + self.gain * hi);
        (a.min(b).clamp(0.0, 1.0), a.max(b).clamp(0.0, 1.0))
    }
}
