//! What the integration tests of `volga-adf` share.

// Each test file uses the helpers it needs.
#![allow(dead_code)]

use glam::DVec3;
use volga_core::Aabb;

/// A deterministic xorshift generator on `[0, 1)`.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A uniform point of the box.
    pub fn in_box(&mut self, b: &Aabb) -> DVec3 {
        b.min + DVec3::new(self.next(), self.next(), self.next()) * b.size()
    }

    /// A random unit vector (rejection in the unit ball, away from its centre).
    pub fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0;
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}
