use glam::{DVec3, Vec3};

use crate::camera::safe_normalize;
use crate::Camera;

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

/// Blinn-Phong material coefficients of survey eq. 9: `k_a`, `k_d`, `k_s`, `ns`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub ambient: f32,
    pub diffuse: f32,
    pub specular: f32,
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
        }
    }

    pub(crate) fn is_lit(&self) -> bool {
        !self.lights.is_empty()
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
        let view = -ray_dir;
        let len = outward.length();
        let mut n = if len.is_finite() && len > self.min_gradient {
            outward / len
        } else {
            view
        };
        if n.dot(view) < 0.0 {
            n = -n;
        }
        let m = &self.material;
        let mut r = self.ambient * colour;
        for &(l, cl) in &self.lights {
            let n_dot_l = n.dot(l).max(0.0) as f32;
            let h = safe_normalize(l + view);
            let n_dot_h = n.dot(h).max(0.0) as f32;
            let highlight = match self.integer_shininess {
                Some(ns) => n_dot_h.powi(ns),
                None => n_dot_h.powf(m.shininess),
            };
            r += cl * colour * (m.diffuse * n_dot_l) + cl * (m.specular * highlight);
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
