//! The exact references: analytic shapes with their volumes and areas, the
//! Marschner–Lobb signal, and brute-force distances to a mesh.
//!
//! Every shape lies inside the world box `[−1, 1]³` (the scene box of every
//! experiment), with room for a filter band at 32³.

use std::f64::consts::PI;

use glam::{DQuat, DVec3};
use volga_core::{Aabb, Field};
use volga_mesh::{point_triangle_distance_squared, winding_number, TriMesh};
use volga_shapes::{Cone, SignedDistance, Sphere, Torus};

/// Half the edge of the world box `[−1, 1]³` every experiment voxelizes.
pub const SCENE_HALF_WIDTH: f64 = 1.0;

/// The world box `[−1, 1]³`.
pub fn scene_box() -> Aabb {
    Aabb::new(DVec3::splat(-SCENE_HALF_WIDTH), DVec3::splat(SCENE_HALF_WIDTH))
}

/// A box with rounded edges and corners: the points within `radius` of the
/// axis-aligned box `center ± half_extents` (a Minkowski sum with a ball). Exact
/// signed distance; flat faces, cylindrical edges and spherical corners in one shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundedBox {
    /// World position of the box's centre.
    pub center: DVec3,
    /// Half the edge lengths of the inner box, before rounding (world units).
    pub half_extents: DVec3,
    /// The rounding radius: how far the surface lies outside the inner box (world units).
    pub radius: f64,
}

impl SignedDistance for RoundedBox {
    /// `|max(q, 0)| + min(max(qx, qy, qz), 0) − r` with `q = |p − c| − b`.
    fn signed_distance(&self, world_pos: DVec3) -> f64 {
        let q = (world_pos - self.center).abs() - self.half_extents;
        q.max(DVec3::ZERO).length() + q.max_element().min(0.0) - self.radius
    }

    fn bounds(&self) -> Aabb {
        let e = self.half_extents + self.radius;
        Aabb::new(self.center - e, self.center + e)
    }
}

/// The analytic shapes of the voxelization experiments, each with its exact volume
/// and surface area.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ReferenceShape {
    /// A ball ([`ReferenceShape::sphere`]).
    Sphere(Sphere),
    /// A ring torus with a tilted axis ([`ReferenceShape::torus`]).
    Torus(Torus),
    /// A rounded box ([`ReferenceShape::rounded_box`]).
    RoundedBox(RoundedBox),
    /// Capped cone: the apex is a point where the normal is undefined and binary
    /// voxels cannot follow the tip.
    Cone(Cone),
}

impl ReferenceShape {
    /// Sphere of radius 0.75, centre off the grid's symmetry planes.
    pub fn sphere() -> Self {
        ReferenceShape::Sphere(Sphere::new(DVec3::new(0.013, -0.007, 0.005), 0.75).expect("valid sphere"))
    }

    /// Torus R = 0.55, r = 0.22, axis tilted away from the grid axes.
    pub fn torus() -> Self {
        let axis = DVec3::new(0.2, 0.3, 1.0).normalize();
        ReferenceShape::Torus(Torus::new(DVec3::new(0.011, 0.004, -0.006), axis, 0.55, 0.22).expect("valid torus"))
    }

    /// Box 1.0 × 0.7 × 0.5 rounded by 0.15, axis-aligned (flat faces on grid planes).
    pub fn rounded_box() -> Self {
        ReferenceShape::RoundedBox(RoundedBox {
            center: DVec3::new(0.009, -0.004, 0.007),
            half_extents: DVec3::new(0.5, 0.35, 0.25),
            radius: 0.15,
        })
    }

    /// Cone with its apex at z = −0.7, half-angle 30°, height 1.3 (base radius 0.75).
    pub fn cone() -> Self {
        ReferenceShape::Cone(
            Cone::new(DVec3::new(0.006, 0.003, -0.7), DVec3::Z, 30f64.to_radians(), Some(1.3)).expect("valid cone"),
        )
    }

    /// All four, in the order tables list them.
    pub fn all() -> [ReferenceShape; 4] {
        [Self::sphere(), Self::torus(), Self::rounded_box(), Self::cone()]
    }

    /// The shape's name in tables and plots (`sphere`, `torus`, `rounded box`, `cone`).
    pub fn name(&self) -> &'static str {
        match self {
            ReferenceShape::Sphere(_) => "sphere",
            ReferenceShape::Torus(_) => "torus",
            ReferenceShape::RoundedBox(_) => "rounded box",
            ReferenceShape::Cone(_) => "cone",
        }
    }

    /// Exact volume (world units³).
    pub fn volume(&self) -> f64 {
        match self {
            ReferenceShape::Sphere(s) => 4.0 / 3.0 * PI * s.radius().powi(3),
            ReferenceShape::Torus(t) => 2.0 * PI * PI * t.major_radius() * t.minor_radius().powi(2),
            // Steiner's formula for a box grown by a ball: V + S·r + (π/4)·ΣL·r² + (4/3)π r³.
            ReferenceShape::RoundedBox(b) => {
                let [x, y, z] = b.half_extents.to_array();
                let r = b.radius;
                8.0 * x * y * z
                    + 8.0 * (x * y + y * z + z * x) * r
                    + 2.0 * PI * (x + y + z) * r * r
                    + 4.0 / 3.0 * PI * r.powi(3)
            }
            ReferenceShape::Cone(_) => {
                let (radius, height) = CONE_BASE;
                PI * radius * radius * height / 3.0
            }
        }
    }

    /// Exact surface area (world units²).
    pub fn area(&self) -> f64 {
        match self {
            ReferenceShape::Sphere(s) => 4.0 * PI * s.radius().powi(2),
            ReferenceShape::Torus(t) => 4.0 * PI * PI * t.major_radius() * t.minor_radius(),
            // d/dr of the volume: S + (π/2)·ΣL·r + 4π r².
            ReferenceShape::RoundedBox(b) => {
                let [x, y, z] = b.half_extents.to_array();
                let r = b.radius;
                8.0 * (x * y + y * z + z * x) + 4.0 * PI * (x + y + z) * r + 4.0 * PI * r * r
            }
            ReferenceShape::Cone(_) => {
                let (radius, height) = CONE_BASE;
                PI * radius * radius + PI * radius * (radius * radius + height * height).sqrt()
            }
        }
    }
}

/// Base radius and height of [`ReferenceShape::cone`].
const CONE_BASE: (f64, f64) = (1.3 * 0.577_350_269_189_625_8, 1.3);

impl SignedDistance for ReferenceShape {
    fn signed_distance(&self, world_pos: DVec3) -> f64 {
        match self {
            ReferenceShape::Sphere(s) => s.signed_distance(world_pos),
            ReferenceShape::Torus(s) => s.signed_distance(world_pos),
            ReferenceShape::RoundedBox(s) => s.signed_distance(world_pos),
            ReferenceShape::Cone(s) => s.signed_distance(world_pos),
        }
    }

    fn bounds(&self) -> Aabb {
        match self {
            ReferenceShape::Sphere(s) => s.bounds(),
            ReferenceShape::Torus(s) => s.bounds(),
            ReferenceShape::RoundedBox(s) => s.bounds(),
            ReferenceShape::Cone(s) => s.bounds(),
        }
    }

    fn gradient(&self, p: DVec3) -> DVec3 {
        match self {
            ReferenceShape::Sphere(s) => s.gradient(p),
            ReferenceShape::Torus(s) => s.gradient(p),
            ReferenceShape::RoundedBox(s) => s.gradient(p),
            ReferenceShape::Cone(s) => s.gradient(p),
        }
    }
}

/// The Marschner–Lobb test signal (survey §5; Marschner & Lobb 1994) on `[−1, 1]³`:
/// `ρ = (1 − sin(πz/2) + α(1 + cos(2π f_M cos(πr/2)))) / (2(1 + α))`, `r = √(x² + y²)`,
/// with `f_M = 6`, `α = ¼`. Sampled on 41³ points it is nearly critically sampled,
/// so it shows what a reconstruction filter loses; the iso-surface is `ρ = ½`.
#[derive(Debug, Clone, Copy, Default)]
pub struct MarschnerLobb;

impl MarschnerLobb {
    const F_M: f64 = 6.0;
    const ALPHA: f64 = 0.25;
    /// The iso value rendered.
    pub const ISO: f64 = 0.5;
    /// Spacing of the classic 41³ sampling (world units).
    pub const SPACING: f64 = 0.05;

    /// The signal ρ at world position `p`, in \[0, 1\].
    pub fn density(p: DVec3) -> f64 {
        let r = (p.x * p.x + p.y * p.y).sqrt();
        let rho_r = (2.0 * PI * Self::F_M * (PI * r / 2.0).cos()).cos();
        (1.0 - (PI * p.z / 2.0).sin() + Self::ALPHA * (1.0 + rho_r)) / (2.0 * (1.0 + Self::ALPHA))
    }

    /// Analytic gradient of [`MarschnerLobb::density`].
    pub fn density_gradient(p: DVec3) -> DVec3 {
        let r = (p.x * p.x + p.y * p.y).sqrt();
        let norm = 2.0 * (1.0 + Self::ALPHA);
        let dz = -(PI / 2.0) * (PI * p.z / 2.0).cos() / norm;
        if r == 0.0 {
            return DVec3::new(0.0, 0.0, dz);
        }
        let inner = 2.0 * PI * Self::F_M * (PI * r / 2.0).cos();
        // d/dr cos(inner) = −sin(inner) · 2π f_M · (−sin(πr/2) · π/2)
        let drho_dr = inner.sin() * 2.0 * PI * Self::F_M * (PI * r / 2.0).sin() * (PI / 2.0);
        let dr = Self::ALPHA * drho_dr / norm;
        DVec3::new(dr * p.x / r, dr * p.y / r, dz)
    }
}

impl Field for MarschnerLobb {
    fn bounds(&self) -> Aabb {
        scene_box()
    }

    fn value(&self, world_pos: DVec3) -> f64 {
        Self::density(world_pos)
    }

    fn gradient(&self, world_pos: DVec3) -> DVec3 {
        Self::density_gradient(world_pos)
    }

    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(Self::SPACING)
    }

    fn value_range(&self, _world_box: &Aabb) -> (f64, f64) {
        (f64::NEG_INFINITY, f64::INFINITY)
    }
}

/// A closed torus mesh (R = 0.55, r = 0.22, `major × minor` quads split in two,
/// outward-facing), rotated off the grid axes: the input of the mesh experiments.
pub fn torus_mesh(major_segments: u32, minor_segments: u32) -> TriMesh {
    let (big, small) = (0.55, 0.22);
    let rotation = DQuat::from_rotation_arc(DVec3::Z, DVec3::new(0.2, 0.3, 1.0).normalize());
    let offset = DVec3::new(0.011, 0.004, -0.006);
    let mut positions = Vec::new();
    for i in 0..major_segments {
        let u = 2.0 * PI * i as f64 / major_segments as f64;
        for j in 0..minor_segments {
            let v = 2.0 * PI * j as f64 / minor_segments as f64;
            let ring = big + small * v.cos();
            let p = DVec3::new(ring * u.cos(), ring * u.sin(), small * v.sin());
            positions.push(offset + rotation * p);
        }
    }
    let index = |i: u32, j: u32| (i % major_segments) * minor_segments + (j % minor_segments);
    let mut triangles = Vec::new();
    for i in 0..major_segments {
        for j in 0..minor_segments {
            let (a, b, c, d) = (index(i, j), index(i + 1, j), index(i + 1, j + 1), index(i, j + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    TriMesh::new(positions, triangles).expect("finite torus mesh")
}

/// Exact signed distance to a closed mesh by brute force: the smallest
/// point–triangle distance over every triangle, negative where the generalized
/// winding number (summed over every triangle) is `≥ ½`.
pub fn mesh_signed_distance(mesh: &TriMesh, world_pos: DVec3) -> f64 {
    let d2 = (0..mesh.triangle_count())
        .map(|i| point_triangle_distance_squared(world_pos, mesh.triangle(i)))
        .fold(f64::INFINITY, f64::min);
    let d = d2.sqrt();
    if winding_number(mesh, world_pos) >= 0.5 {
        -d
    } else {
        d
    }
}

/// A deterministic point of `[0, 1)³` for index `i` (the R3 low-discrepancy
/// sequence of Roberts 2018): the sample positions of the experiments, the same for
/// any thread count.
pub fn r3_point(i: u64) -> DVec3 {
    // Inverse powers of the plastic-like constant for three dimensions.
    const G: f64 = 1.220_744_084_605_759_5;
    let a = DVec3::new(1.0 / G, 1.0 / (G * G), 1.0 / (G * G * G));
    let v = DVec3::splat(0.5) + a * (i as f64 + 1.0);
    v - v.floor()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// splitmix64: an independent pseudo-random stream for the Monte-Carlo checks.
    struct Rng(u64);
    impl Rng {
        fn next_f64(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
        fn point(&mut self) -> DVec3 {
            DVec3::new(self.next_f64(), self.next_f64(), self.next_f64()) * 2.0 - 1.0
        }
    }

    /// Monte-Carlo volume of `{d ≤ 0}` and area from the shell `{|d| ≤ ε}` (its
    /// volume is `2ε·A` plus `O(ε³)`), with the standard error of each.
    fn monte_carlo(shape: &ReferenceShape, samples: u64, eps: f64) -> (f64, f64, f64, f64) {
        let mut rng = Rng(0x5EED ^ shape.name().len() as u64);
        let (mut inside, mut shell) = (0u64, 0u64);
        for _ in 0..samples {
            let d = shape.signed_distance(rng.point());
            inside += (d <= 0.0) as u64;
            shell += (d.abs() <= eps) as u64;
        }
        let box_volume = 8.0;
        let n = samples as f64;
        let fraction = |k: u64| k as f64 / n;
        let se = |k: u64| box_volume * (fraction(k) * (1.0 - fraction(k)) / n).sqrt();
        (
            box_volume * fraction(inside),
            se(inside),
            box_volume * fraction(shell) / (2.0 * eps),
            se(shell) / (2.0 * eps),
        )
    }

    #[test]
    fn analytic_volumes_and_areas_match_monte_carlo() {
        for shape in ReferenceShape::all() {
            let (v, v_se, a, a_se) = monte_carlo(&shape, 2_000_000, 0.01);
            assert!(
                (v - shape.volume()).abs() < 4.0 * v_se,
                "{}: volume {} vs Monte Carlo {v} ± {v_se}",
                shape.name(),
                shape.volume()
            );
            // The shell's O(ε³) curvature term is below 1e-4 relative here.
            assert!(
                (a - shape.area()).abs() < 4.0 * a_se + 1e-3 * shape.area(),
                "{}: area {} vs Monte Carlo {a} ± {a_se}",
                shape.name(),
                shape.area()
            );
        }
    }

    #[test]
    fn a_wrong_volume_would_be_caught() {
        // The check above can fail: a 2 % error is many standard errors.
        let shape = ReferenceShape::torus();
        let (v, v_se, _, _) = monte_carlo(&shape, 2_000_000, 0.01);
        assert!((v - 1.02 * shape.volume()).abs() > 4.0 * v_se);
    }

    /// The rounded box's distance against its definition: the distance to the inner
    /// box (by clamping) minus the radius outside it, and minus the depth below the
    /// box's nearest face inside it.
    #[test]
    fn rounded_box_distance_matches_its_definition() {
        let ReferenceShape::RoundedBox(b) = ReferenceShape::rounded_box() else {
            unreachable!()
        };
        let mut rng = Rng(7);
        for _ in 0..20_000 {
            let p = rng.point();
            let local = p - b.center;
            let clamped = local.clamp(-b.half_extents, b.half_extents);
            let to_box = if clamped == local {
                -(b.half_extents - local.abs()).min_element()
            } else {
                (local - clamped).length()
            };
            assert!((b.signed_distance(p) - (to_box - b.radius)).abs() < 1e-12, "{p}");
        }
    }

    #[test]
    fn marschner_lobb_gradient_matches_differences() {
        let mut rng = Rng(11);
        for _ in 0..2000 {
            let p = rng.point() * 0.95;
            let h = 1e-6;
            let fd = DVec3::new(
                MarschnerLobb::density(p + DVec3::X * h) - MarschnerLobb::density(p - DVec3::X * h),
                MarschnerLobb::density(p + DVec3::Y * h) - MarschnerLobb::density(p - DVec3::Y * h),
                MarschnerLobb::density(p + DVec3::Z * h) - MarschnerLobb::density(p - DVec3::Z * h),
            ) / (2.0 * h);
            assert!((fd - MarschnerLobb::density_gradient(p)).length() < 1e-5, "{p}");
        }
        // Range and the classic values: ρ(0, 0, 0) = (1 + α(1 + cos 12π)) / 2.5 = 0.6.
        assert!((MarschnerLobb::density(DVec3::ZERO) - 0.6).abs() < 1e-12);
    }

    /// Point–triangle distance by a second path: the plane projection when it falls
    /// inside the triangle (barycentric test), else the nearest of the three edges.
    fn distance_second_path(p: DVec3, [a, b, c]: [DVec3; 3]) -> f64 {
        let segment = |s: DVec3, e: DVec3| {
            let t = ((p - s).dot(e - s) / (e - s).length_squared()).clamp(0.0, 1.0);
            (p - (s + (e - s) * t)).length()
        };
        let n = (b - a).cross(c - a);
        let q = p - n * (p - a).dot(n) / n.length_squared();
        let inside = [(a, b), (b, c), (c, a)]
            .iter()
            .all(|&(s, e)| (e - s).cross(q - s).dot(n) >= 0.0);
        if inside {
            (p - q).length()
        } else {
            segment(a, b).min(segment(b, c)).min(segment(c, a))
        }
    }

    #[test]
    fn mesh_distance_reference_matches_a_second_brute_force_path() {
        let mesh = torus_mesh(24, 12);
        let torus = ReferenceShape::torus();
        for i in 0..300 {
            let p = r3_point(i) * 2.0 - 1.0;
            let d = mesh_signed_distance(&mesh, p);
            let second = (0..mesh.triangle_count())
                .map(|t| distance_second_path(p, mesh.triangle(t)))
                .fold(f64::INFINITY, f64::min);
            assert!((d.abs() - second).abs() < 1e-12, "{p}: {d} vs {second}");
            // The sign against the analytic torus the mesh approximates, away from
            // the faceting error (chord sag ≤ R(1 − cos(π/24)) + r(1 − cos(π/12)) < 0.02).
            let analytic = torus.signed_distance(p);
            if analytic.abs() > 0.03 {
                assert_eq!(d < 0.0, analytic < 0.0, "{p}: {d} vs analytic {analytic}");
                assert!((d - analytic).abs() < 0.03, "{p}: {d} vs analytic {analytic}");
            }
        }
    }
}
