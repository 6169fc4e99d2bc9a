use glam::{DVec3, Vec3};

use crate::camera::safe_normalize;
use crate::error::bad_setting;
use crate::settings::check_finite_nonneg;
use crate::{Camera, RenderError};

/// A directional light.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Direction *towards* the light in world space; need not be unit length.
    pub direction: DVec3,
    /// Linear RGB colour `C_l` of survey eq. 9.
    pub colour: Vec3,
}

impl Light {
    /// A white light shining from the camera along its view direction (a
    /// "headlight"): surfaces facing the viewer are fully lit.
    pub fn headlight(camera: &Camera) -> Light {
        Light {
            direction: -camera.forward(),
            colour: Vec3::ONE,
        }
    }
}

/// A point light: it shines from `position` in every direction, towards a sample at
/// `p` along `L = (position − p)/|position − p|`, with colour
/// `colour / (c + l·d + q·d²)` at distance `d` ([`Attenuation`]).
#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    /// World position of the light.
    pub position: DVec3,
    /// Linear RGB colour `C_l` of survey eq. 9 (at distance 0 when attenuated).
    pub colour: Vec3,
    /// How the colour falls off with distance; [`PointLight::new`] sets none
    /// ([`Attenuation::NONE`]). The coefficients must be finite and ≥ 0 with at least
    /// one positive (checked as `lighting.point_lights[i].attenuation`).
    pub attenuation: Attenuation,
}

impl PointLight {
    /// A light of `colour` at `position`, not attenuated with distance.
    pub fn new(position: DVec3, colour: Vec3) -> Self {
        PointLight {
            position,
            colour,
            attenuation: Attenuation::NONE,
        }
    }

    pub(crate) fn validate(&self, path: &str) -> Result<(), RenderError> {
        if !self.position.is_finite() {
            return Err(bad_setting(
                format!("{path}.position"),
                format!("must be finite, got {}", self.position),
            ));
        }
        check_finite_nonneg(format!("{path}.colour"), &self.colour.to_array())?;
        let a = &self.attenuation;
        check_finite_nonneg(
            format!("{path}.attenuation"),
            &[a.constant as f32, a.linear as f32, a.quadratic as f32],
        )?;
        if !(a.constant > 0.0 || a.linear > 0.0 || a.quadratic > 0.0) {
            return Err(bad_setting(
                format!("{path}.attenuation"),
                "at least one coefficient must be > 0",
            ));
        }
        Ok(())
    }
}

/// Distance attenuation of a [`PointLight`]: the colour is divided by
/// `constant + linear·d + quadratic·d²` at world distance `d`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Attenuation {
    /// Constant term `c` of the divisor; finite and ≥ 0.
    pub constant: f64,
    /// Coefficient `l` of the distance `d` (per world unit); finite and ≥ 0.
    pub linear: f64,
    /// Coefficient `q` of `d²` (per square world unit); finite and ≥ 0.
    pub quadratic: f64,
}

impl Attenuation {
    /// No attenuation: `(1, 0, 0)`.
    pub const NONE: Attenuation = Attenuation {
        constant: 1.0,
        linear: 0.0,
        quadratic: 0.0,
    };

    /// The inverse square law, `1/d²` (infinite at the light: keep lights off the surfaces).
    pub const INVERSE_SQUARE: Attenuation = Attenuation {
        constant: 0.0,
        linear: 0.0,
        quadratic: 1.0,
    };

    /// The factor `1/(c + l·d + q·d²)` at world distance `d`, finite (at most 10⁶).
    #[inline]
    pub fn factor(&self, d: f64) -> f32 {
        let den = self.constant + d * (self.linear + d * self.quadratic);
        if den > 1e-6 {
            (1.0 / den) as f32
        } else {
            1e6
        }
    }
}

impl Default for Attenuation {
    fn default() -> Self {
        Attenuation::NONE
    }
}

/// Names one light of a [`Lighting`](crate::Lighting): an index into its `lights`
/// (directional) or its `point_lights`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightId {
    /// Index into [`Lighting::lights`](crate::Lighting::lights).
    Directional(usize),
    /// Index into [`Lighting::point_lights`](crate::Lighting::point_lights).
    Point(usize),
}

/// Blinn-Phong material coefficients of survey eq. 9: `k_a`, `k_d`, `k_s`, `ns`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// `k_a`: weight of the ambient term `C_a·C_o`, added whatever the light directions;
    /// finite and ≥ 0, default 0.15.
    pub ambient: f32,
    /// `k_d`: weight of the diffuse term `C_l·C_o·max(N·L, 0)`; finite and ≥ 0,
    /// default 0.75.
    pub diffuse: f32,
    /// `k_s`: weight of the highlight `C_l·max(N·H, 0)^ns`, in the light's colour (not
    /// tinted by `C_o`); finite and ≥ 0, default 0.3.
    pub specular: f32,
    /// `ns`: the highlight exponent, larger for smaller, sharper highlights; finite and
    /// ≥ 0, default 32.
    pub shininess: f32,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            ambient: 0.15,
            diffuse: 0.75,
            specular: 0.3,
            shininess: 32.0,
        }
    }
}

/// Precomputed lighting for one render: unit light directions and coefficients.
#[derive(Clone, Debug)]
pub(crate) struct Shader {
    lights: Vec<(DVec3, Vec3)>,
    /// `k_a · C_a`.
    ambient: Vec3,
    material: Material,
    /// The shininess as an integer when it is one (up to 1024): `x^ns` is then
    /// `powi`, repeated squaring, instead of a libm `powf` per sample and light.
    integer_shininess: Option<i32>,
    /// Gradients shorter than this are treated as zero (no defined normal).
    min_gradient: f64,
    /// Point lights: position, colour, attenuation.
    points: Vec<(DVec3, Vec3, Attenuation)>,
    /// Per light (the directional ones first, then the point lights): whether it
    /// casts shadows.
    shadowed: Vec<bool>,
    /// Point lights or shadows: samples are shaded by [`RayShader::shade_general`].
    general: bool,
}

impl Shader {
    pub(crate) fn new(lights: &[Light], ambient_colour: Vec3, material: Material, spacing: f64) -> Self {
        Shader {
            lights: lights.iter().map(|l| (safe_normalize(l.direction), l.colour)).collect(),
            ambient: ambient_colour * material.ambient,
            material,
            integer_shininess: (material.shininess.fract() == 0.0 && (0.0..=1024.0).contains(&material.shininess))
                .then_some(material.shininess as i32),
            min_gradient: 1e-9 / spacing,
            points: Vec::new(),
            shadowed: vec![false; lights.len()],
            general: false,
        }
    }

    /// The shader of `lighting`: its directional and point lights, shadows where
    /// [`ShadowSettings::casters`](crate::ShadowSettings::casters) asks.
    pub(crate) fn from_lighting(lighting: &crate::Lighting, spacing: f64) -> Self {
        let mut s = Shader::new(&lighting.lights, lighting.ambient_colour, lighting.material, spacing);
        s.points = lighting
            .point_lights
            .iter()
            .map(|p| (p.position, p.colour, p.attenuation))
            .collect();
        let nd = lighting.lights.len();
        s.shadowed = vec![false; nd + s.points.len()];
        for c in &lighting.shadows.casters {
            let k = match *c {
                LightId::Directional(i) => i,
                LightId::Point(i) => nd + i,
            };
            if let Some(f) = s.shadowed.get_mut(k) {
                *f = true;
            }
        }
        s.general = !s.points.is_empty() || s.shadowed.iter().any(|&f| f);
        s
    }

    pub(crate) fn is_lit(&self) -> bool {
        !self.lights.is_empty() || !self.points.is_empty()
    }

    /// Whether samples need [`RayShader::shade_general`] (point lights or shadows)
    /// rather than [`RayShader::shade`].
    #[inline]
    pub(crate) fn is_general(&self) -> bool {
        self.general
    }

    /// Blinn-Phong reflection, survey eq. 9 with the half vector `H`:
    /// `R = k_a·C_a·C_o + Σ_l [k_d·C_l·C_o·max(N·L, 0) + k_s·C_l·max(N·H, 0)^ns]`.
    ///
    /// `N = outward/|outward|`, where `outward` is the field's outward direction
    /// ([`FieldKind::outward`](volga_core::FieldKind::outward) of the gradient: `−∇f`
    /// for densities, `+∇f` for signed distances), flipped towards the viewer
    /// (two-sided lighting); `−ray_dir` where it vanishes or is not finite.
    /// `ray_dir` must be unit length.
    #[inline]
    pub(crate) fn shade(&self, colour: Vec3, outward: DVec3, ray_dir: DVec3) -> Vec3 {
        self.for_ray(ray_dir).shade(colour, outward)
    }

    /// The shader for the samples of one ray: the half vectors `H = (L + V)/|L + V|`
    /// depend on the ray's direction only, so they are normalized once per ray (the
    /// first [`CACHED_HALVES`] lights; more are normalized per sample). Same bits as
    /// [`Shader::shade`].
    #[inline]
    pub(crate) fn for_ray(&self, ray_dir: DVec3) -> RayShader<'_> {
        let view = -ray_dir;
        let mut halves = [DVec3::ZERO; CACHED_HALVES];
        for (h, (l, _)) in halves.iter_mut().zip(&self.lights) {
            *h = safe_normalize(*l + view);
        }
        RayShader {
            shader: self,
            view,
            halves,
        }
    }
}

/// A [`Shader`]'s lights and coefficients, for the packed path's `f32` shading.
pub(crate) struct ShaderParts<'s> {
    pub(crate) lights: &'s [(DVec3, Vec3)],
    pub(crate) ambient: Vec3,
    pub(crate) material: Material,
    pub(crate) integer_shininess: Option<i32>,
    pub(crate) min_gradient: f64,
}

impl Shader {
    /// The unit light directions and colours, `k_a·C_a`, the material, the integer
    /// shininess and the smallest gradient shaded (read by `packet.rs`).
    pub(crate) fn parts(&self) -> ShaderParts<'_> {
        ShaderParts {
            lights: &self.lights,
            ambient: self.ambient,
            material: self.material,
            integer_shininess: self.integer_shininess,
            min_gradient: self.min_gradient,
        }
    }
}

/// `x^n` for `n ≥ 0` by repeated squaring, the algorithm of compiler-rt's
/// `__powisf2` (what `f32::powi` calls for a run-time exponent), inlined: the same bits
/// without a call per sample and light.
#[inline(always)]
pub(crate) fn powi(mut x: f32, mut n: i32) -> f32 {
    debug_assert!(n >= 0);
    let mut r = 1.0f32;
    loop {
        if n & 1 != 0 {
            r *= x;
        }
        n /= 2;
        if n == 0 {
            return r;
        }
        x *= x;
    }
}

/// Lights whose half vectors [`Shader::for_ray`] normalizes once per ray.
const CACHED_HALVES: usize = 8;

/// [`Shader`] with the view and half vectors of one ray.
pub(crate) struct RayShader<'s> {
    shader: &'s Shader,
    view: DVec3,
    halves: [DVec3; CACHED_HALVES],
}

impl RayShader<'_> {
    /// The unit normal `outward/|outward|` flipped towards the viewer (two-sided
    /// lighting); `−ray_dir` where `outward` vanishes or is not finite.
    #[inline]
    fn normal(&self, outward: DVec3) -> DVec3 {
        let len = outward.length();
        let n = if len.is_finite() && len > self.shader.min_gradient {
            outward * len.recip()
        } else {
            self.view
        };
        if n.dot(self.view) < 0.0 {
            -n
        } else {
            n
        }
    }

    /// [`Shader::shade`] for this ray's direction.
    #[inline]
    pub(crate) fn shade(&self, colour: Vec3, outward: DVec3) -> Vec3 {
        let s = self.shader;
        let view = self.view;
        let n = self.normal(outward);
        let m = &s.material;
        let mut r = s.ambient * colour;
        for (i, &(l, cl)) in s.lights.iter().enumerate() {
            let n_dot_l = n.dot(l).max(0.0) as f32;
            let h = if i < CACHED_HALVES {
                self.halves[i]
            } else {
                safe_normalize(l + view)
            };
            let n_dot_h = n.dot(h).max(0.0) as f32;
            let highlight = match s.integer_shininess {
                Some(ns) => powi(n_dot_h, ns),
                None => n_dot_h.powf(m.shininess),
            };
            r += cl * colour * (m.diffuse * n_dot_l) + cl * (m.specular * highlight);
        }
        r
    }

    /// Survey eq. 9 with the light colours of eq. 10: like [`RayShader::shade`], over
    /// the directional and the point lights, each light's colour scaled by its
    /// attenuation and, for a light that casts shadows, by `visibility(k, L, distance)`
    /// (the transmittance towards light `k` — directional lights first, then point
    /// lights — along unit `L`, over the world distance to the light, ∞ for a
    /// directional one). `visibility` is called only for shadowed
    /// lights that would add light (`N·L > 0` or a highlight), and for `opaque_surface`
    /// (an iso-surface) not at all when `N·L ≤ 0`: the light is then behind the
    /// surface, which shadows itself.
    #[inline]
    pub(crate) fn shade_general(
        &self,
        colour: Vec3,
        outward: DVec3,
        p: DVec3,
        opaque_surface: bool,
        mut visibility: impl FnMut(usize, DVec3, f64) -> f32,
    ) -> Vec3 {
        let s = self.shader;
        let view = self.view;
        let n = self.normal(outward);
        let m = &s.material;
        let mut r = s.ambient * colour;
        let nd = s.lights.len();
        let lights = s.lights.iter().map(|&(l, cl)| (l, f64::INFINITY, cl));
        let points = s.points.iter().map(|&(pos, cl, att)| {
            let v = pos - p;
            let d = v.length();
            (safe_normalize(v), d, cl * att.factor(d))
        });
        for (i, (l, dist, cl)) in lights.chain(points).enumerate() {
            let n_dot_l = n.dot(l);
            let h = if i < CACHED_HALVES && i < nd {
                self.halves[i]
            } else {
                safe_normalize(l + view)
            };
            let n_dot_h = n.dot(h).max(0.0) as f32;
            let highlight = match s.integer_shininess {
                Some(ns) => powi(n_dot_h, ns),
                None => n_dot_h.powf(m.shininess),
            };
            let diffuse = n_dot_l.max(0.0) as f32;
            let mut cl = cl;
            if s.shadowed[i] {
                if opaque_surface && n_dot_l <= 0.0 {
                    continue;
                }
                if diffuse == 0.0 && highlight == 0.0 {
                    continue;
                }
                cl *= visibility(i, l, dist);
            }
            r += cl * colour * (m.diffuse * diffuse) + cl * (m.specular * highlight);
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn facing_light_is_brightest_and_two_sided() {
        let lights = [Light {
            direction: DVec3::new(0.0, 0.0, 2.0),
            colour: Vec3::ONE,
        }];
        let s = Shader::new(&lights, Vec3::ONE, Material::default(), 1.0);
        let dir = -DVec3::Z;
        let co = Vec3::new(0.8, 0.4, 0.2);
        // Outward normal +z: ambient + diffuse + full specular.
        let front = s.shade(co, DVec3::Z, dir);
        let m = Material::default();
        let want = co * (m.ambient + m.diffuse) + Vec3::splat(m.specular);
        assert!((front - want).abs().max_element() < 1e-6, "{front} vs {want}");
        // A normal pointing the other way is flipped towards the viewer.
        assert_eq!(s.shade(co, -DVec3::Z, dir), front);
        // Zero gradient: N = −ray dir.
        assert_eq!(s.shade(co, DVec3::ZERO, dir), front);
        assert_eq!(s.shade(co, DVec3::splat(f64::NAN), dir), front);
        // Oblique normal is darker.
        let oblique = s.shade(co, DVec3::new(1.0, 0.0, 0.2), dir);
        assert!(oblique.x < front.x);
        assert!(oblique.is_finite());
        // Integer shininess (repeated squaring) and fractional (powf) agree.
        for ns in [32.0, 32.000_004, 7.0, 0.0] {
            let m = Material {
                shininess: ns,
                ..Material::default()
            };
            let s = Shader::new(&lights, Vec3::ONE, m, 1.0);
            assert_eq!(s.integer_shininess.is_some(), ns.fract() == 0.0, "{ns}");
            let normal = DVec3::new(0.3, 0.1, 1.0);
            let got = s.shade(co, normal, dir);
            let n = normal.normalize();
            let h = (DVec3::Z + DVec3::Z).normalize();
            let want = co * m.ambient
                + co * (m.diffuse * n.dot(DVec3::Z) as f32)
                + Vec3::splat(m.specular * (n.dot(h) as f32).powf(ns));
            assert!((got - want).abs().max_element() < 1e-5, "{ns}: {got} vs {want}");
        }
    }
}
