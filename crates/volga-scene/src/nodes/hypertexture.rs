//! Leaf node: a Perlin–Hoffert hypertexture (survey §17.7) on an analytic sphere or on a
//! sampled volume (through the exact Euclidean distance transform of its voxels, as
//! Satherley & Jones do). Density is 1 inside, 0 outside, and shaped by the modulation
//! chain in the soft band only; noise runs nowhere else (the report counts it).
//! The presets of figure 44 are scene files: `scenes/fig44_*.ron`.

use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};
use volga_core::{Aabb, Field, Grid};
use volga_shapes::Sphere;
use volga_texture::{edt, DistanceSource, HyperTexture, Modulation, SampledDistance, ShapeSource, TextureError};

use super::procedural::{NodeCounters, NoiseSpec};
use super::{bricks_within, Clipped, Estimate, Node, Resolve};
use crate::ctx::Ctx;
use crate::model::V3;
use crate::SceneError;

/// `Hypertexture(object: Sphere(center: .., radius: ..), soft_width: .., chain: [..])`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HypertextureSpec {
    /// A label for the report; default `hypertextureN`, N counting the tree's leaf nodes
    /// (objects, `Fuzzy`, `Volume`, `Hypertexture`, `Adf`) in file order from 0.
    #[serde(default)]
    pub name: Option<String>,
    /// The solid the texture grows from: `Sphere(center, radius)` or
    /// `Volume(path, translate)`.
    pub object: HyperObjectSpec,
    /// Half-width of the soft band (world units): density `½ − d/(2·soft_width)` there.
    pub soft_width: f64,
    /// Modulation steps applied in order to the soft band's density `t` (or, for
    /// `Displace`, to the distance `d`); default none.
    #[serde(default)]
    pub chain: Vec<ModulationSpec>,
    /// Linear RGB in \[0, 1\] of the whole hypertexture; white when absent.
    #[serde(default)]
    pub colour: Option<V3>,
}

/// The object a hypertexture grows from: density 1 inside, 0 outside, soft only within the
/// band around its surface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum HyperObjectSpec {
    /// An analytic ball.
    Sphere {
        /// World position of the centre.
        center: V3,
        /// Radius in world units, finite and > 0.
        radius: f64,
    },
    /// A voxel model (`.binvox` or density `.nrrd`, relative to the scene file), moved
    /// by `translate`: inside where density > ½, its signed distance by the exact EDT
    /// on the model's grid padded by the soft band's reach.
    Volume {
        /// The file, relative to the scene file's folder; read in the resolve stage, and
        /// refused when it or its padded distance grid exceeds the memory limit.
        path: String,
        /// Offset from where the file places the model (world units); default `(0, 0, 0)`.
        #[serde(default)]
        translate: V3,
    },
}

/// Most modulation steps a hypertexture's chain may have.
pub const MAX_CHAIN: usize = 64;
/// Largest offset (world units, per axis) a `Volume` object may be moved by: sums and
/// products of world coordinates stay finite (as for sculpts, [`volga_sculpt::MAX_WORLD`]).
pub const MAX_TRANSLATE: f64 = 1e100;

/// One step of the modulation chain, applied to the soft band only.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ModulationSpec {
    /// `d ← d − amplitude · noise(p ⊙ stretch)`.
    Displace {
        /// The noise sampled at `p ⊙ stretch`.
        noise: NoiseSpec,
        /// World units the surface moves per unit of noise, finite (negative moves it the
        /// other way).
        amplitude: f64,
        /// Per-axis factors on the noise's input position, finite (e.g. `(1, 0.3, 1)`
        /// stretches the pattern along y); default `(1, 1, 1)`.
        #[serde(default = "ones")]
        stretch: V3,
    },
    /// Strands along the surface normals: `t ← t · bias(sharpness, ½ + ½·noise(foot))`
    /// with `foot` the point moved onto the surface along the distance gradient.
    Fur {
        /// The noise sampled at each point's foot on the surface.
        noise: NoiseSpec,
        /// Strand sharpness `b` of Perlin's bias, in \[0, 1\].
        sharpness: f64,
    },
    /// `t ← t · (1 + amplitude · noise(p))`, clamped to \[0, 1\].
    Scale {
        /// The noise sampled at each point.
        noise: NoiseSpec,
        /// Relative change of `t` per unit of noise, finite.
        amplitude: f64,
    },
    /// `t ← bias(b, t)`: Perlin's bias with `b` in \[0, 1\] (½ leaves `t` unchanged,
    /// below ½ lowers the densities, above raises them).
    Bias(f64),
    /// `t ← gain(g, t)`: Perlin's gain with `g` in \[0, 1\] (½ leaves `t` unchanged,
    /// above ½ steepens the ramp around ½, below flattens it).
    Gain(f64),
}

fn ones() -> V3 {
    [1.0; 3]
}

#[derive(Debug)]
enum Object {
    Sphere(Sphere),
    Volume {
        path: String,
        field: String,
        translate: DVec3,
    },
}

/// Leaf node: a Perlin–Hoffert hypertexture on a ball or a voxel model
/// (`NodeSpec::Hypertexture`); noise runs only in the soft band.
#[derive(Debug)]
pub struct HypertextureNode {
    name: String,
    object: Object,
    soft_width: f64,
    chain: Option<Vec<Modulation>>,
    colour: Option<Vec3>,
    hyper: Option<HyperTexture>,
}

impl HypertextureNode {
    /// Checks a `Hypertexture` spec at field path `f` (`root.Hypertexture`); `index`
    /// numbers its default name `hypertexture{index}`. A ball's hypertexture is built now,
    /// a volume's in the resolve stage.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] naming the field refused, e.g. `{f}.soft_width` or
    /// `{f}.chain[2].Fur.sharpness`.
    pub fn validate(cx: &Ctx, f: &str, spec: &HypertextureSpec, index: usize) -> Result<Self, SceneError> {
        let soft_width = cx.positive(&format!("{f}.soft_width"), spec.soft_width)?;
        let object = match &spec.object {
            HyperObjectSpec::Sphere { center, radius } => {
                let c = cx.finite3(&format!("{f}.object.Sphere.center"), *center)?;
                let r = cx.positive(&format!("{f}.object.Sphere.radius"), *radius)?;
                Object::Sphere(Sphere::new(c, r).map_err(|e| cx.err(format!("{f}.object.Sphere"), e.to_string()))?)
            }
            HyperObjectSpec::Volume { path, translate } => {
                if path.is_empty() {
                    return Err(cx.err(
                        format!("{f}.object.Volume.path"),
                        "must name a .binvox, .nrrd or .vdb file",
                    ));
                }
                let tf = format!("{f}.object.Volume.translate");
                let translate = cx.finite3(&tf, *translate)?;
                if translate.abs().max_element() > MAX_TRANSLATE {
                    return Err(cx.err(
                        tf,
                        format!("must lie within ±{MAX_TRANSLATE:e} world units on every axis, got {translate}"),
                    ));
                }
                Object::Volume {
                    path: path.clone(),
                    field: format!("{f}.object.Volume.path"),
                    translate,
                }
            }
        };
        if spec.chain.len() > MAX_CHAIN {
            return Err(cx.err(
                format!("{f}.chain"),
                format!(
                    "{} modulation steps: at most {MAX_CHAIN} (each runs at every sample of the soft band)",
                    spec.chain.len()
                ),
            ));
        }
        let mut chain = Vec::new();
        for (i, m) in spec.chain.iter().enumerate() {
            let mf = format!("{f}.chain[{i}]");
            chain.push(match m {
                ModulationSpec::Displace {
                    noise,
                    amplitude,
                    stretch,
                } => Modulation::Displace {
                    noise: noise.validate(cx, &format!("{mf}.Displace.noise"))?,
                    amplitude: finite(cx, &format!("{mf}.Displace.amplitude"), *amplitude)?,
                    stretch: cx.finite3(&format!("{mf}.Displace.stretch"), *stretch)?,
                },
                ModulationSpec::Fur { noise, sharpness } => Modulation::Fur {
                    noise: noise.validate(cx, &format!("{mf}.Fur.noise"))?,
                    sharpness: unit(cx, &format!("{mf}.Fur.sharpness"), *sharpness)?,
                },
                ModulationSpec::Scale { noise, amplitude } => Modulation::Scale {
                    noise: noise.validate(cx, &format!("{mf}.Scale.noise"))?,
                    amplitude: finite(cx, &format!("{mf}.Scale.amplitude"), *amplitude)?,
                },
                ModulationSpec::Bias(b) => Modulation::Bias(unit(cx, &format!("{mf}.Bias"), *b)?),
                ModulationSpec::Gain(g) => Modulation::Gain(unit(cx, &format!("{mf}.Gain"), *g)?),
            });
        }
        let colour = match spec.colour {
            Some(c) => Some(Vec3::from(cx.colour(&format!("{f}.colour"), Some(c))?)),
            None => None,
        };
        let mut node = HypertextureNode {
            name: spec.name.clone().unwrap_or_else(|| format!("hypertexture{index}")),
            object,
            soft_width,
            chain: Some(chain),
            colour,
            hyper: None,
        };
        if let Object::Sphere(s) = &node.object {
            let distance = Box::new(ShapeSource(*s));
            node.build(distance, soft_width / 8.0)
                .map_err(|e| cx.err(f, e.to_string()))?;
        }
        Ok(node)
    }

    /// The kernel hypertexture of `distance` (its arguments were validated with the
    /// scene's fields; an error here names the kernel's argument).
    fn build(&mut self, distance: Box<dyn DistanceSource + Send>, spacing: f64) -> Result<(), TextureError> {
        let chain = self.chain.take().unwrap_or_default();
        let mut h = HyperTexture::new(distance, self.soft_width, chain, spacing)?;
        if let Some(c) = self.colour {
            h = h.with_colour(c);
        }
        self.hyper = Some(h);
        Ok(())
    }

    /// The kernel hypertexture (after resolving, for volumes).
    pub fn hypertexture(&self) -> Option<&HyperTexture> {
        self.hyper.as_ref()
    }
}

/// How far a modulation can move the surface (as `HyperTexture` bounds it).
fn displacement_bound(m: &Modulation) -> f64 {
    match m {
        Modulation::Displace { noise, amplitude, .. } => {
            let (lo, hi) = noise.range();
            amplitude.abs() * lo.abs().max(hi.abs())
        }
        _ => 0.0,
    }
}

fn finite(cx: &Ctx, f: &str, v: f64) -> Result<f64, SceneError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(cx.err(f, format!("must be finite, got {v}")))
    }
}

fn unit(cx: &Ctx, f: &str, v: f64) -> Result<f64, SceneError> {
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(cx.err(f, format!("must lie in [0, 1], got {v}")))
    }
}

impl Node for HypertextureNode {
    fn kind(&self) -> &'static str {
        "hypertexture"
    }
    fn name(&self) -> &str {
        &self.name
    }
    fn colour(&self) -> volga_core::Rgb {
        self.colour.unwrap_or(Vec3::ONE).to_array()
    }
    fn resolve(&mut self, cx: &Resolve) -> Result<(), SceneError> {
        if let Object::Volume { path, field, translate } = &self.object {
            let volume = super::volume::load_density(cx, path, field)?;
            let g = &volume.grid;
            let spacing = g.transform.spacing();
            // Pad by the band's reach (plus one voxel) so the soft band lies inside the
            // distance grid; beyond it the distance is +∞ (outside).
            let displacement: f64 = self
                .chain
                .as_deref()
                .map_or(0.0, |c| c.iter().map(displacement_bound).sum());
            let reach = self.soft_width + displacement;
            let pad = ((reach / spacing.min_element()).ceil() as i64 + 1).clamp(1, 256) as i32;
            let d = g.dims().as_ivec3() + 2 * pad;
            let voxels = d.x as u64 * d.y as u64 * d.z as u64;
            if voxels.saturating_mul(24) > cx.memory_limit {
                return Err(SceneError::Invalid {
                    path: cx.scene.to_owned(),
                    field: field.clone(),
                    message: format!("the padded distance grid ({d}) exceeds the memory limit"),
                });
            }
            let origin = g.transform.origin() - spacing * pad as f64 + *translate;
            let transform = volga_core::Transform::new(origin, spacing).map_err(|e| SceneError::Invalid {
                path: cx.scene.to_owned(),
                field: field.clone(),
                message: e.to_string(),
            })?;
            let grid = Grid::new(transform, d.as_uvec3()).map_err(|e| SceneError::Invalid {
                path: cx.scene.to_owned(),
                field: field.clone(),
                message: e.to_string(),
            })?;
            let n = [d.x as usize, d.y as usize, d.z as usize];
            let mut inside = vec![false; n[0] * n[1] * n[2]];
            for (i, v) in inside.iter_mut().enumerate() {
                let ijk = glam::IVec3::new(
                    (i % n[0]) as i32,
                    ((i / n[0]) % n[1]) as i32,
                    (i / (n[0] * n[1])) as i32,
                );
                *v = volume.density.get(ijk - pad) > 0.5;
            }
            let sd = edt::signed_distance(&inside, n, spacing.to_array());
            let field = field.clone();
            let invalid = |e: TextureError| SceneError::Invalid {
                path: cx.scene.to_owned(),
                field: field.clone(),
                message: e.to_string(),
            };
            let distance = SampledDistance::new(grid, sd).map_err(&invalid)?;
            self.build(Box::new(distance), spacing.min_element())
                .map_err(&invalid)?;
        }
        Ok(())
    }
    fn bounds(&self) -> Aabb {
        match &self.hyper {
            Some(h) => h.bounds(),
            None => Aabb::new(DVec3::splat(f64::NEG_INFINITY), DVec3::splat(f64::INFINITY)),
        }
    }
    fn estimate(&self, grid: &Grid) -> Estimate {
        Estimate {
            bricks: bricks_within(grid, &self.bounds()),
            extra_bytes: 0,
        }
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        let h = self.hyper.as_ref().ok_or_else(|| SceneError::Invalid {
            path: Default::default(),
            field: self.name.clone(),
            message: "the hypertexture's volume was not loaded (resolve stage)".into(),
        })?;
        let mut clipped = Clipped::new(h, grid.world_bounds());
        if let Some(c) = self.colour {
            clipped = clipped.tinted(c.to_array());
        }
        Ok(Box::new(clipped))
    }
    fn procedural_plan(&self) -> Option<String> {
        let reach = self.hyper.as_ref().map_or(self.soft_width, |h| h.reach());
        Some(format!(
            "noise only in the soft band (|d| < {reach:.4} world units: soft width {} plus the chain's displacement bound); boxes wholly inside or outside are settled by their distance range",
            self.soft_width
        ))
    }
    fn counters(&self) -> Vec<NodeCounters> {
        vec![NodeCounters {
            node: self.name.clone(),
            kind: self.kind().into(),
            samples: self.hyper.as_ref().map_or(0, |h| h.samples()),
            noise_evaluations: self.hyper.as_ref().map_or(0, |h| h.noise_evaluations()),
        }]
    }
}
