//! Solid textures (survey §17.6): a scalar pattern of world position mapped through a
//! colour spline, "carved out" of a material. Presets: marble (turbulence-perturbed
//! sine stripes), wood (turbulence-perturbed rings around an axis), cells (Worley
//! F2 − F1), and the plain noise and turbulence bases of figure 43.

use glam::{DVec3, Vec3};

use crate::{Perlin, SolidNoise, TextureError, Turbulence, Worley};

/// A piecewise-linear colour spline over \[0, 1\]: knots sorted by position; values
/// outside the first and last knot take their colours.
#[derive(Debug, Clone, PartialEq)]
pub struct ColourSpline {
    knots: Vec<(f64, Vec3)>,
}

impl ColourSpline {
    /// Knots as `(position, linear RGB)`: at least one, finite, positions increasing.
    /// Refuses the first knot that is not ([`TextureError::NoKnots`],
    /// [`TextureError::KnotNotFinite`], [`TextureError::KnotOrder`]).
    pub fn new(knots: Vec<(f64, Vec3)>) -> Result<Self, TextureError> {
        if knots.is_empty() {
            return Err(TextureError::NoKnots);
        }
        for (index, &(position, colour)) in knots.iter().enumerate() {
            if !(position.is_finite() && colour.is_finite()) {
                return Err(TextureError::KnotNotFinite {
                    index,
                    position,
                    colour,
                });
            }
        }
        for (index, w) in knots.windows(2).enumerate() {
            if w[1].0 <= w[0].0 {
                return Err(TextureError::KnotOrder {
                    index: index + 1,
                    position: w[1].0,
                    previous: w[0].0,
                });
            }
        }
        Ok(ColourSpline { knots })
    }

    /// The colour at `t`: linear between the knots around it, the end knots' colours
    /// beyond them.
    pub fn at(&self, t: f64) -> Vec3 {
        let k = &self.knots;
        let i = k.partition_point(|(p, _)| *p <= t);
        if i == 0 {
            return k[0].1;
        }
        if i == k.len() {
            return k[k.len() - 1].1;
        }
        let (t0, c0) = k[i - 1];
        let (t1, c1) = k[i];
        c0.lerp(c1, ((t - t0) / (t1 - t0)) as f32)
    }
}

/// Which pattern a solid texture draws.
#[derive(Debug, Clone)]
pub enum Pattern {
    /// `½ + ½·noise(p·frequency)`.
    Noise(Perlin, f64),
    /// Turbulence scaled into \[0, 1\].
    Turbulence(Turbulence),
    /// `½ + ½·sin(2π·frequency·(p·direction) + strength·turbulence(p))`.
    Marble {
        /// The turbulence that perturbs the stripes.
        turbulence: Turbulence,
        /// Stripes per world unit along `direction`.
        frequency: f64,
        /// The direction across the stripes.
        direction: DVec3,
        /// How far the turbulence moves the stripes (radians per unit of turbulence).
        strength: f64,
    },
    /// `fract(rings·distance-to-axis + strength·turbulence(p))`, the axis through
    /// `center` along `axis` (unit).
    Wood {
        /// The turbulence that perturbs the rings.
        turbulence: Turbulence,
        /// A point of the axis (world space).
        center: DVec3,
        /// The axis's unit direction.
        axis: DVec3,
        /// Rings per world unit of distance to the axis.
        rings: f64,
        /// How far the turbulence moves the rings (rings per unit of turbulence).
        strength: f64,
    },
    /// Worley `F2 − F1` (cell units) clamped to \[0, 1\]: dark on cell borders.
    Cells(Worley),
}

/// A pattern and its colour spline.
#[derive(Debug, Clone)]
pub struct SolidTexture {
    /// The scalar in \[0, 1\] of world position.
    pub pattern: Pattern,
    /// The colour of each scalar value.
    pub spline: ColourSpline,
}

impl Pattern {
    /// The pattern's value in \[0, 1\].
    pub fn scalar(&self, p: DVec3) -> f64 {
        match self {
            Pattern::Noise(n, f) => 0.5 + 0.5 * n.value(p * *f),
            Pattern::Turbulence(t) => t.value(p) / t.range().1,
            Pattern::Marble {
                turbulence,
                frequency,
                direction,
                strength,
            } => {
                let phase = std::f64::consts::TAU * frequency * p.dot(*direction) + strength * turbulence.value(p);
                0.5 + 0.5 * phase.sin()
            }
            Pattern::Wood {
                turbulence,
                center,
                axis,
                rings,
                strength,
            } => {
                let q = p - *center;
                let r = (q - *axis * q.dot(*axis)).length();
                let v = rings * r + strength * turbulence.value(p);
                v - v.floor()
            }
            Pattern::Cells(w) => {
                let (f1, f2) = w.f1_f2(p);
                (f2 - f1).clamp(0.0, 1.0)
            }
        }
    }

    /// Noise evaluations (Perlin octaves or Worley searches) one [`Pattern::scalar`] costs.
    pub fn noise_cost(&self) -> u64 {
        match self {
            Pattern::Noise(..) | Pattern::Cells(_) => 1,
            Pattern::Turbulence(t) | Pattern::Marble { turbulence: t, .. } | Pattern::Wood { turbulence: t, .. } => {
                t.octaves() as u64
            }
        }
    }
}

impl SolidTexture {
    /// The texture's colour at world position `p` (linear RGB).
    pub fn colour(&self, p: DVec3) -> Vec3 {
        self.spline.at(self.pattern.scalar(p))
    }

    fn spline(knots: &[(f64, [f32; 3])]) -> ColourSpline {
        ColourSpline::new(knots.iter().map(|(t, c)| (*t, Vec3::from(*c))).collect()).expect("preset knots increase")
    }

    /// White marble with grey-blue veins; `scale` is the vein spacing (world units).
    pub fn marble(seed: u32, scale: f64) -> Self {
        SolidTexture {
            pattern: Pattern::Marble {
                turbulence: Turbulence::new(seed, 5, 2.0 / scale),
                frequency: 1.0 / scale,
                direction: DVec3::X,
                strength: 5.0,
            },
            spline: Self::spline(&[
                (0.0, [0.25, 0.27, 0.35]),
                (0.25, [0.65, 0.66, 0.7]),
                (0.6, [0.92, 0.92, 0.9]),
                (1.0, [0.98, 0.97, 0.95]),
            ]),
        }
    }

    /// Wood rings around the y axis through `center`; `ring_width` in world units.
    pub fn wood(seed: u32, center: DVec3, ring_width: f64) -> Self {
        SolidTexture {
            pattern: Pattern::Wood {
                turbulence: Turbulence::new(seed, 4, 1.0 / (4.0 * ring_width)),
                center,
                axis: DVec3::Y,
                rings: 1.0 / ring_width,
                strength: 1.5,
            },
            spline: Self::spline(&[
                (0.0, [0.55, 0.33, 0.14]),
                (0.6, [0.72, 0.48, 0.24]),
                (0.85, [0.42, 0.23, 0.09]),
                (1.0, [0.55, 0.33, 0.14]),
            ]),
        }
    }

    /// Worley cells of `cell_size` world units: light cells, dark borders.
    pub fn cells(seed: u32, cell_size: f64) -> Self {
        SolidTexture {
            pattern: Pattern::Cells(Worley::new(seed, 1.0 / cell_size)),
            spline: Self::spline(&[
                (0.0, [0.1, 0.05, 0.02]),
                (0.15, [0.75, 0.3, 0.15]),
                (0.6, [0.95, 0.75, 0.4]),
            ]),
        }
    }
}
