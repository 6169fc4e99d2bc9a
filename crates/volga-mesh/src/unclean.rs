//! Meshes as users bring them, made on purpose: self-intersecting unions, overlapping
//! and nested copies, flipped parts, open scans, flat sheets, single triangles and
//! quads, far from the origin. Each is small (hundreds to a few thousand triangles) so
//! a brute-force winding number over it is cheap; tests and the `sign_check` example
//! hold volga's inside/outside against that reference on every one.

use glam::{DAffine3, DVec3};

use crate::TriMesh;

/// A closed, outward-oriented UV sphere (`rings` ≥ 2 bands, `segments` ≥ 3 around).
pub fn uv_sphere(center: DVec3, radius: f64, rings: u32, segments: u32) -> TriMesh {
    let (rings, segments) = (rings.max(2), segments.max(3));
    let mut positions = vec![center + DVec3::Z * radius];
    for r in 1..rings {
        let theta = std::f64::consts::PI * r as f64 / rings as f64;
        for s in 0..segments {
            let phi = std::f64::consts::TAU * s as f64 / segments as f64;
            positions.push(center + radius * DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()));
        }
    }
    positions.push(center - DVec3::Z * radius);
    let south = positions.len() as u32 - 1;
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let mut triangles = Vec::new();
    for s in 0..segments {
        triangles.push([0, ring(1, s), ring(1, s + 1)]);
        triangles.push([south, ring(rings - 1, s + 1), ring(rings - 1, s)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (ring(r, s), ring(r, s + 1), ring(r + 1, s), ring(r + 1, s + 1));
            triangles.push([a, c, d]);
            triangles.push([a, d, b]);
        }
    }
    TriMesh { positions, triangles }
}

/// A height-field sheet over `[-1, 1]²` (open, `n × n` quads), `z = amplitude · sin(πx) cos(πy)`.
pub fn sheet(n: u32, amplitude: f64) -> TriMesh {
    let n = n.max(1);
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (-1.0 + 2.0 * i as f64 / n as f64, -1.0 + 2.0 * j as f64 / n as f64);
            let z = amplitude * (std::f64::consts::PI * x).sin() * (std::f64::consts::PI * y).cos();
            positions.push(DVec3::new(x, y, z));
        }
    }
    let at = |i: u32, j: u32| j * (n + 1) + i;
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    TriMesh { positions, triangles }
}

/// Both meshes in one (no welding across them).
pub fn concat(a: &TriMesh, b: &TriMesh) -> TriMesh {
    let offset = a.positions.len() as u32;
    TriMesh {
        positions: a.positions.iter().chain(&b.positions).copied().collect(),
        triangles: a
            .triangles
            .iter()
            .copied()
            .chain(b.triangles.iter().map(|t| t.map(|i| i + offset)))
            .collect(),
    }
}

/// The mesh with the triangles `flip` selects (by centroid) reversed.
pub fn flipped_where(mesh: &TriMesh, flip: impl Fn(DVec3) -> bool) -> TriMesh {
    let mut out = mesh.clone();
    for (i, t) in out.triangles.iter_mut().enumerate() {
        let [a, b, c] = mesh.triangle(i);
        if flip((a + b + c) / 3.0) {
            t.swap(1, 2);
        }
    }
    out
}

/// The mesh without the triangles `cut` selects (by centroid): an open scan.
pub fn cut_where(mesh: &TriMesh, cut: impl Fn(DVec3) -> bool) -> TriMesh {
    let mut out = mesh.clone();
    out.triangles = (0..mesh.triangles.len())
        .filter(|&i| {
            let [a, b, c] = mesh.triangle(i);
            !cut((a + b + c) / 3.0)
        })
        .map(|i| mesh.triangles[i])
        .collect();
    out
}

/// The unclean corpus: named meshes, each a case the inside/outside promise must hold on.
pub fn corpus() -> Vec<(&'static str, TriMesh)> {
    let sphere = uv_sphere(DVec3::ZERO, 1.0, 16, 24);
    let shifted = uv_sphere(DVec3::new(0.7, 0.2, 0.1), 0.8, 14, 20);
    let tri = TriMesh {
        positions: vec![
            DVec3::new(-1.0, -0.8, 0.1),
            DVec3::new(1.0, -0.5, -0.2),
            DVec3::new(0.1, 1.0, 0.3),
        ],
        triangles: vec![[0, 1, 2]],
    };
    let quad = TriMesh {
        positions: vec![
            DVec3::new(-1.0, -1.0, 0.0),
            DVec3::new(1.0, -1.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(-1.0, 1.0, 0.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    };
    let rotate = DAffine3::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    vec![
        ("closed sphere", sphere.clone()),
        ("self-intersecting union of two spheres", concat(&sphere, &shifted)),
        ("overlapping identical copies", concat(&sphere, &sphere)),
        (
            "overlapping shifted copies",
            concat(&sphere, &sphere.translated(DVec3::new(0.05, 0.03, 0.0))),
        ),
        (
            "nested spheres, same orientation",
            concat(&sphere, &uv_sphere(DVec3::new(0.1, 0.0, 0.0), 0.5, 10, 14)),
        ),
        (
            "sphere with a flipped hemisphere",
            flipped_where(&sphere, |c| c.x > 0.0),
        ),
        (
            "open scan (sphere with a cap cut off)",
            cut_where(&sphere, |c| c.z > 0.6),
        ),
        (
            "open scan with two holes",
            cut_where(&sphere, |c| c.z > 0.7 || (c.x > 0.8 && c.y.abs() < 0.3)),
        ),
        ("flat sheet", sheet(12, 0.0)),
        ("wavy sheet", sheet(16, 0.3)),
        (
            "stacked sheets",
            concat(&sheet(8, 0.0), &sheet(8, 0.0).translated(DVec3::Z * 0.02)),
        ),
        ("single triangle", tri.clone()),
        ("single triangle, other winding", flipped_where(&tri, |_| true)),
        ("single quad", quad.transformed(&rotate)),
        ("closed sphere at 1e6", sphere.translated(DVec3::splat(1e6))),
        ("single triangle at 1e6", tri.translated(DVec3::new(1e6, -1e6, 1e6))),
        (
            "sheet pierced by a sphere",
            concat(&sheet(10, 0.0), &uv_sphere(DVec3::new(0.2, 0.1, 0.0), 0.5, 10, 14)),
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_is_closed_and_outward() {
        let s = uv_sphere(DVec3::ZERO, 1.0, 8, 12);
        assert!(s.is_closed());
        assert!((crate::winding_number(&s, DVec3::ZERO) - 1.0).abs() < 1e-9);
        assert!(crate::winding_number(&s, DVec3::splat(2.0)).abs() < 1e-9);
    }

    #[test]
    fn corpus_has_the_promised_defects() {
        let corpus = corpus();
        let get = |name: &str| &corpus.iter().find(|(n, _)| *n == name).unwrap().1;
        assert!(!get("open scan (sphere with a cap cut off)").is_closed());
        assert!(!get("flat sheet").is_closed());
        // Nested: w = 2 inside the inner sphere.
        assert!(
            (crate::winding_number(get("nested spheres, same orientation"), DVec3::new(0.1, 0.0, 0.0)) - 2.0).abs()
                < 1e-9
        );
        // Identical copies: w = 2 inside.
        assert!((crate::winding_number(get("overlapping identical copies"), DVec3::ZERO) - 2.0).abs() < 1e-9);
    }
}
