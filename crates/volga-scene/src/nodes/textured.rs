//! Operator node: a solid texture (survey §17.6) painting its operand: density from the
//! operand, colour from a pattern (noise, turbulence, marble, wood, Worley cells) through
//! a colour spline, evaluated where a colour is read — at render time for lazy images,
//! into the colour channel when baking. An image that reads no colour evaluates no noise.

use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};
use volga_core::{Aabb, Field, Grid};
use volga_texture::{ColourSpline, Pattern, Perlin, SolidTexture, Turbulence};

use super::procedural::{Counters, NodeCounters};
use super::{Estimate, Node, Resolve};
use crate::ctx::Ctx;
use crate::model::{NodeSpec, V3};
use crate::SceneError;

/// `Textured(texture: Marble(scale: 0.3), operand: Object(..), spline: [..])`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TexturedSpec {
    /// A label for the report; default the node's field path (`root.Textured`).
    #[serde(default)]
    pub name: Option<String>,
    /// The pattern: `Noise`, `Turbulence`, `Marble`, `Wood` or `Cells`, each with a preset
    /// colour ramp.
    pub texture: TextureSpec,
    /// The node whose density is kept; its colour is replaced by the texture's.
    pub operand: Box<NodeSpec>,
    /// `(position in [0, 1], linear RGB)` knots, increasing; the preset's when absent.
    #[serde(default)]
    pub spline: Option<Vec<(f64, V3)>>,
}

/// A solid texture's pattern: a value in \[0, 1\] at each world point, which `spline` (or
/// the preset ramp) turns into a colour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum TextureSpec {
    /// `½ + ½·noise(frequency·p)`, grey ramp by default.
    Noise {
        /// Seed of the noise's permutation; default 0.
        #[serde(default)]
        seed: u32,
        /// Frequency in periods per world unit, finite and > 0.
        frequency: f64,
    },
    /// Turbulence scaled to \[0, 1\], grey ramp by default.
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
    /// White marble with grey-blue veins: `½ + ½·sin(2π·x/scale + 5·turbulence(p))`, veins
    /// across the x axis.
    Marble {
        /// Seed of the turbulence; default 0.
        #[serde(default)]
        seed: u32,
        /// Vein period along x (world units), finite and > 0.
        scale: f64,
    },
    /// Wood rings around the vertical line (along y) through `center`, perturbed by
    /// turbulence.
    Wood {
        /// Seed of the turbulence; default 0.
        #[serde(default)]
        seed: u32,
        /// A world point on the rings' axis.
        center: V3,
        /// Distance between rings (world units), finite and > 0.
        ring_width: f64,
    },
    /// Worley cells (`F2 − F1`): light cells with dark borders.
    Cells {
        /// Seed of the cell points; default 0.
        #[serde(default)]
        seed: u32,
        /// Typical cell size (world units), finite and > 0.
        cell_size: f64,
    },
}

fn four() -> u32 {
    4
}

/// Operator node: a solid texture colouring its operand (`NodeSpec::Textured`); the texture
/// is evaluated only where a colour is read.
#[derive(Debug)]
pub struct TexturedNode {
    name: String,
    texture: SolidTexture,
    children: Vec<Box<dyn Node>>,
    counters: Counters,
}

impl TexturedNode {
    /// Checks a `Textured` spec at field path `f` (`root.Textured`) and its operand;
    /// `leaves` counts the leaf nodes met so far, for their default names.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] naming the field refused, e.g. `{f}.texture.Marble.scale` or
    /// `{f}.spline` (knots not increasing).
    pub fn validate(cx: &Ctx, f: &str, spec: &TexturedSpec, leaves: &mut usize) -> Result<Self, SceneError> {
        let tf = format!("{f}.texture");
        let grey = ColourSpline::new(vec![(0.0, Vec3::splat(0.05)), (1.0, Vec3::ONE)]).expect("increasing knots");
        let mut texture = match &spec.texture {
            TextureSpec::Noise { seed, frequency } => SolidTexture {
                pattern: Pattern::Noise(
                    Perlin::new(*seed),
                    cx.positive(&format!("{tf}.Noise.frequency"), *frequency)?,
                ),
                spline: grey,
            },
            TextureSpec::Turbulence {
                seed,
                octaves,
                frequency,
            } => {
                if !(1..=16).contains(octaves) {
                    return Err(cx.err(
                        format!("{tf}.Turbulence.octaves"),
                        format!("must be in 1..=16, got {octaves}"),
                    ));
                }
                SolidTexture {
                    pattern: Pattern::Turbulence(Turbulence::new(
                        *seed,
                        *octaves,
                        cx.positive(&format!("{tf}.Turbulence.frequency"), *frequency)?,
                    )),
                    spline: grey,
                }
            }
            TextureSpec::Marble { seed, scale } => {
                SolidTexture::marble(*seed, cx.positive(&format!("{tf}.Marble.scale"), *scale)?)
            }
            TextureSpec::Wood {
                seed,
                center,
                ring_width,
            } => SolidTexture::wood(
                *seed,
                cx.finite3(&format!("{tf}.Wood.center"), *center)?,
                cx.positive(&format!("{tf}.Wood.ring_width"), *ring_width)?,
            ),
            TextureSpec::Cells { seed, cell_size } => {
                SolidTexture::cells(*seed, cx.positive(&format!("{tf}.Cells.cell_size"), *cell_size)?)
            }
        };
        if let Some(knots) = &spec.spline {
            for (i, (_, c)) in knots.iter().enumerate() {
                cx.colour(&format!("{f}.spline[{i}]"), Some(*c))?;
            }
            texture.spline = ColourSpline::new(knots.iter().map(|(t, c)| (*t, DVec3::from(*c).as_vec3())).collect())
                .map_err(|_| {
                    cx.err(
                        format!("{f}.spline"),
                        "needs at least one knot, positions finite and increasing",
                    )
                })?;
        }
        let child = super::union::node(cx, &format!("{f}.operand"), &spec.operand, leaves)?;
        Ok(TexturedNode {
            name: spec.name.clone().unwrap_or_else(|| f.to_string()),
            texture,
            children: vec![child],
            counters: Counters::default(),
        })
    }
}

/// The operand's density with the texture's colour.
struct TexturedField<'a> {
    density: Box<dyn Field + 'a>,
    node: &'a TexturedNode,
}

impl std::fmt::Debug for TexturedField<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TexturedField").field("node", &self.node.name).finish()
    }
}

impl Field for TexturedField<'_> {
    fn bounds(&self) -> Aabb {
        self.density.bounds()
    }
    fn kind(&self) -> volga_core::FieldKind {
        self.density.kind()
    }
    fn background(&self) -> f64 {
        self.density.background()
    }
    fn value(&self, world_pos: DVec3) -> f64 {
        self.node.counters.samples.add(1);
        self.density.value(world_pos)
    }
    fn gradient_step(&self) -> DVec3 {
        self.density.gradient_step()
    }
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        self.density.value_range(world_box)
    }
    fn has_colour(&self) -> bool {
        true
    }
    fn colour(&self, world_pos: DVec3) -> Option<Vec3> {
        self.node.counters.noise.add(self.node.texture.pattern.noise_cost());
        Some(self.node.texture.colour(world_pos))
    }
    fn sample_spacing(&self) -> f64 {
        self.density.sample_spacing()
    }
}

impl Node for TexturedNode {
    fn kind(&self) -> &'static str {
        "textured"
    }
    fn name(&self) -> &str {
        &self.name
    }
    fn children(&self) -> &[Box<dyn Node>] {
        &self.children
    }
    fn resolve(&mut self, cx: &Resolve) -> Result<(), SceneError> {
        self.children.iter_mut().try_for_each(|c| c.resolve(cx))
    }
    fn bounds(&self) -> Aabb {
        self.children[0].bounds()
    }
    fn estimate(&self, grid: &Grid) -> Estimate {
        self.children[0].estimate(grid)
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        Ok(Box::new(TexturedField {
            density: self.children[0].lazy_field(grid)?,
            node: self,
        }))
    }
    fn procedural_plan(&self) -> Option<String> {
        Some("texture colour evaluated only where a colour is read (lazy colour images, or the baked colour channel when planned), at voxels of non-zero density".into())
    }
    fn counters(&self) -> Vec<NodeCounters> {
        vec![NodeCounters {
            node: self.name.clone(),
            kind: self.kind().into(),
            samples: self.counters.samples.get(),
            noise_evaluations: self.counters.noise.get(),
        }]
    }
}
