//! Shared pieces of the procedural node kinds (`cvg`, `fuzzy`, `volume`, `textured`,
//! `hypertexture`): the noise specs of scene files, the per-node counters the report
//! lists, and baking through `volga_cvg::bake` (only the bricks a node can reach, each
//! settled by its value range before any voxel is sampled).

use serde::{Deserialize, Serialize};
use volga_core::{Field, Grid, SparseVolume};
use volga_texture::{Counter, Fbm, Scaled, SolidNoise, Turbulence};

use crate::ctx::Ctx;
use crate::SceneError;

/// A noise of a scene file (survey §17.6). Frequencies are periods per world unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum NoiseSpec {
    /// Perlin noise in \[-1, 1\].
    Perlin {
        /// Seed of the noise's permutation; default 0.
        #[serde(default)]
        seed: u32,
        /// Frequency in periods per world unit, finite and > 0.
        frequency: f64,
    },
    /// Perlin's turbulence Σ|noise(2ⁱ·f·x)|/2ⁱ, i < octaves.
    Turbulence {
        /// Seed of the noise's permutation; default 0.
        #[serde(default)]
        seed: u32,
        /// Number of octaves, 1 to 16; default 4.
        #[serde(default = "four")]
        octaves: u32,
        /// Frequency of the first octave in periods per world unit, finite and > 0.
        frequency: f64,
    },
    /// fBm as the `noise` crate's `Fbm<Perlin>` (lacunarity 2, persistence ½).
    Fbm {
        /// Seed of the noise's permutation; default 0.
        #[serde(default)]
        seed: u32,
        /// Number of octaves, 1 to 16; default 4.
        #[serde(default = "four")]
        octaves: u32,
        /// Frequency of the first octave in periods per world unit, finite and > 0.
        frequency: f64,
    },
}

fn four() -> u32 {
    4
}

impl NoiseSpec {
    /// The kernel noise; `f` is the field path of this spec.
    pub fn validate(&self, cx: &Ctx, f: &str) -> Result<Box<dyn SolidNoise>, SceneError> {
        let octaves = |o: u32, name: &str| {
            if (1..=16).contains(&o) {
                Ok(o)
            } else {
                Err(cx.err(format!("{f}.{name}.octaves"), format!("must be in 1..=16, got {o}")))
            }
        };
        Ok(match self {
            NoiseSpec::Perlin { seed, frequency } => Box::new(Scaled::new(
                *seed,
                cx.positive(&format!("{f}.Perlin.frequency"), *frequency)?,
            )),
            NoiseSpec::Turbulence {
                seed,
                octaves: o,
                frequency,
            } => Box::new(Turbulence::new(
                *seed,
                octaves(*o, "Turbulence")?,
                cx.positive(&format!("{f}.Turbulence.frequency"), *frequency)?,
            )),
            NoiseSpec::Fbm {
                seed,
                octaves: o,
                frequency,
            } => Box::new(Fbm::new(
                *seed,
                octaves(*o, "Fbm")? as usize,
                cx.positive(&format!("{f}.Fbm.frequency"), *frequency)?,
                2.0,
                0.5,
            )),
        })
    }
}

/// What one node did, for `report.json`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct NodeCounters {
    /// The node's name (as in the scene, or its default).
    pub node: String,
    /// The node's kind (`fuzzy`, `volume`, `hypertexture`, …).
    pub kind: String,
    /// Density samples taken of this node (lazy renders and baking).
    pub samples: u64,
    /// Perlin evaluations (one per octave) and Worley searches.
    pub noise_evaluations: u64,
}

/// Counters a node keeps across renders and bakes.
#[derive(Debug, Default)]
pub struct Counters {
    /// Density samples taken (lazy renders and baking).
    pub samples: Counter,
    /// Noise evaluations: one per Perlin octave, one per Worley search.
    pub noise: Counter,
}

/// Bakes a node's lazy field on the bricks of `grid` that meet `clip` (see the module
/// doc; [`volga_cvg::bake_in`]); `clip = grid.index_box()` bakes the whole grid.
pub fn bake_field_in(field: &dyn Field, grid: &Grid, colour: bool, clip: &volga_core::IndexBox) -> SparseVolume {
    volga_cvg::bake_in(field, grid, colour, clip).0
}

/// A field that counts its samples (value calls and batch entries).
pub struct Counted<'a, F> {
    /// The field whose samples are counted.
    pub field: F,
    /// The counter each sample adds one to.
    pub samples: &'a Counter,
}

impl<F: Field> std::fmt::Debug for Counted<'_, F> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Counted").field("bounds", &self.field.bounds()).finish()
    }
}

impl<F: Field> Field for Counted<'_, F> {
    fn bounds(&self) -> volga_core::Aabb {
        self.field.bounds()
    }
    fn kind(&self) -> volga_core::FieldKind {
        self.field.kind()
    }
    fn background(&self) -> f64 {
        self.field.background()
    }
    fn value(&self, world_pos: glam::DVec3) -> f64 {
        self.samples.add(1);
        self.field.value(world_pos)
    }
    fn gradient_step(&self) -> glam::DVec3 {
        self.field.gradient_step()
    }
    fn value_range(&self, world_box: &volga_core::Aabb) -> (f64, f64) {
        self.field.value_range(world_box)
    }
    fn has_colour(&self) -> bool {
        self.field.has_colour()
    }
    fn colour(&self, world_pos: glam::DVec3) -> Option<glam::Vec3> {
        self.field.colour(world_pos)
    }
    fn sample_spacing(&self) -> f64 {
        self.field.sample_spacing()
    }
}
