//! Sums of Perlin octaves: fractional Brownian motion with the `noise` crate's
//! parameters and values ([`Fbm`]), and Perlin's turbulence Σ|noise(2ⁱx)|/2ⁱ
//! ([`Turbulence`], survey §17.6), both as points and as rows.

use glam::DVec3;

use crate::{Perlin, RowHashes};

/// A solid noise: a scalar function of world position with a known bound.
pub trait SolidNoise: Send + Sync + std::fmt::Debug {
    /// The value at a point.
    fn value(&self, p: DVec3) -> f64;
    /// `out[k] = value((x0 + k·dx, y, z))` (up to rounding), the fast path for rows.
    fn row(&self, x0: f64, dx: f64, y: f64, z: f64, out: &mut [f64]) {
        for (k, v) in out.iter_mut().enumerate() {
            *v = self.value(DVec3::new(x0 + k as f64 * dx, y, z));
        }
    }
    /// [`SolidNoise::row`] with per-octave hash caches kept between rows.
    fn row_cached(&self, _cache: &mut Vec<RowHashes>, x0: f64, dx: f64, y: f64, z: f64, out: &mut [f64]) {
        self.row(x0, dx, y, z, out)
    }
    /// `(lo, hi)` containing every value.
    fn range(&self) -> (f64, f64);
    /// Perlin evaluations one value costs (the octaves).
    fn octave_count(&self) -> u32 {
        1
    }
}

/// fBm as the `noise` crate's `Fbm<Perlin>` computes it: octave `i` is the Perlin noise
/// of seed `seed + i` at `p · frequency · lacunarityⁱ`, weighted `persistenceⁱ⁺¹`, and the
/// sum is divided by `Σ persistenceⁱ⁺¹`.
#[derive(Debug, Clone)]
pub struct Fbm {
    octaves: Vec<Perlin>,
    frequency: f64,
    lacunarity: f64,
    persistence: f64,
    scale: f64,
}

impl Fbm {
    /// `octaves` in 1..=32 (clamped, as the `noise` crate does).
    pub fn new(seed: u32, octaves: usize, frequency: f64, lacunarity: f64, persistence: f64) -> Self {
        let octaves = octaves.clamp(1, 32);
        let denom: f64 = (1..=octaves).fold(0.0, |acc, x| acc + persistence.powi(x as i32));
        Fbm {
            octaves: (0..octaves).map(|i| Perlin::new(seed.wrapping_add(i as u32))).collect(),
            frequency,
            lacunarity,
            persistence,
            scale: 1.0 / denom,
        }
    }

    /// The number of octaves (after clamping).
    pub fn octaves(&self) -> usize {
        self.octaves.len()
    }
}

impl SolidNoise for Fbm {
    fn value(&self, p: DVec3) -> f64 {
        let mut p = p * self.frequency;
        let mut attenuation = self.persistence;
        let mut result = 0.0;
        for o in &self.octaves {
            result += o.value(p) * attenuation;
            attenuation *= self.persistence;
            p *= self.lacunarity;
        }
        result * self.scale
    }

    fn row(&self, x0: f64, dx: f64, y: f64, z: f64, out: &mut [f64]) {
        self.row_cached(&mut Vec::new(), x0, dx, y, z, out)
    }

    fn row_cached(&self, cache: &mut Vec<RowHashes>, x0: f64, dx: f64, y: f64, z: f64, out: &mut [f64]) {
        out.fill(0.0);
        cache.resize_with(self.octaves.len(), Default::default);
        let mut f = self.frequency;
        let mut attenuation = self.persistence;
        for (o, c) in self.octaves.iter().zip(cache.iter_mut()) {
            o.add_row_cached(c, x0 * f, dx * f, y * f, z * f, attenuation * self.scale, false, out);
            attenuation *= self.persistence;
            f *= self.lacunarity;
        }
    }

    fn octave_count(&self) -> u32 {
        self.octaves.len() as u32
    }

    fn range(&self) -> (f64, f64) {
        // |octave| ≤ 1, weights sum to 1 after scaling.
        (-1.0, 1.0)
    }
}

/// Perlin's turbulence: `Σ_{i<octaves} |noise(2ⁱ · frequency · p)| / 2ⁱ` with one seed,
/// in \[0, 2 − 2¹⁻ⁿ\].
#[derive(Debug, Clone)]
pub struct Turbulence {
    noise: Perlin,
    octaves: u32,
    frequency: f64,
}

impl Turbulence {
    /// `octaves` in 1..=32 (clamped).
    pub fn octaves(&self) -> u32 {
        self.octaves
    }

    /// Turbulence of the Perlin noise of `seed`: `octaves` (clamped to 1..=32) octaves,
    /// the first at `frequency` (per world unit).
    pub fn new(seed: u32, octaves: u32, frequency: f64) -> Self {
        Turbulence {
            noise: Perlin::new(seed),
            octaves: octaves.clamp(1, 32),
            frequency,
        }
    }
}

impl SolidNoise for Turbulence {
    fn value(&self, p: DVec3) -> f64 {
        let mut sum = 0.0;
        let mut scale = 1.0;
        let p = p * self.frequency;
        for _ in 0..self.octaves {
            sum += self.noise.value(p * scale).abs() / scale;
            scale *= 2.0;
        }
        sum
    }

    fn row(&self, x0: f64, dx: f64, y: f64, z: f64, out: &mut [f64]) {
        self.row_cached(&mut Vec::new(), x0, dx, y, z, out)
    }

    fn row_cached(&self, cache: &mut Vec<RowHashes>, x0: f64, dx: f64, y: f64, z: f64, out: &mut [f64]) {
        out.fill(0.0);
        cache.resize_with(self.octaves as usize, Default::default);
        let mut scale = 1.0;
        let f = self.frequency;
        for c in cache.iter_mut() {
            let s = f * scale;
            self.noise
                .add_row_cached(c, x0 * s, dx * s, y * s, z * s, 1.0 / scale, true, out);
            scale *= 2.0;
        }
    }

    fn octave_count(&self) -> u32 {
        self.octaves
    }

    fn range(&self) -> (f64, f64) {
        (0.0, 2.0 - 2f64.powi(1 - self.octaves as i32))
    }
}

/// Plain Perlin noise at `frequency`.
#[derive(Debug, Clone)]
pub struct Scaled {
    noise: Perlin,
    frequency: f64,
}

impl Scaled {
    /// The Perlin noise of `seed` at `frequency` (per world unit).
    pub fn new(seed: u32, frequency: f64) -> Self {
        Scaled {
            noise: Perlin::new(seed),
            frequency,
        }
    }
}

impl SolidNoise for Scaled {
    fn value(&self, p: DVec3) -> f64 {
        self.noise.value(p * self.frequency)
    }
    fn row(&self, x0: f64, dx: f64, y: f64, z: f64, out: &mut [f64]) {
        out.fill(0.0);
        let f = self.frequency;
        self.noise.add_row(x0 * f, dx * f, y * f, z * f, 1.0, false, out);
    }
    fn range(&self) -> (f64, f64) {
        (-1.0, 1.0)
    }
}

/// Fills a dense `dims` lattice (x fastest) with `noise` at `origin + ijk ⊙ spacing`,
/// z slabs in parallel (rayon); each row is computed by [`SolidNoise::row`] alone, so
/// the result is the same for any thread count.
pub fn fill(noise: &dyn SolidNoise, origin: DVec3, spacing: DVec3, dims: [usize; 3], out: &mut [f32]) {
    use rayon::prelude::*;
    let [nx, ny, _] = dims;
    assert_eq!(out.len(), dims.iter().product::<usize>(), "output holds dims voxels");
    if nx == 0 || ny == 0 {
        return;
    }
    out.par_chunks_mut(nx * ny).enumerate().for_each(|(k, slab)| {
        let mut row = vec![0.0f64; nx];
        let mut cache = Vec::new();
        let z = origin.z + k as f64 * spacing.z;
        for (j, out_row) in slab.chunks_mut(nx).enumerate() {
            let y = origin.y + j as f64 * spacing.y;
            noise.row_cached(&mut cache, origin.x, spacing.x, y, z, &mut row);
            for (o, v) in out_row.iter_mut().zip(&row) {
                *o = *v as f32;
            }
        }
    });
}
