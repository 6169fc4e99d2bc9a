//! Every extraction method on every cube configuration: random trilinear lattices (all 256
//! sign patterns and both sides of every ambiguous face and interior occur), lattices with
//! values exactly at the iso-value, exact shapes with sharp edges, the simplification's
//! bound, the iso-value index, and determinism. Each mesh is checked closed and manifold
//! from its triangles alone (edge–face incidence, vertex links).

use glam::{DVec3, IVec3};
use volga_core::{Aabb, Field, FieldKind};
mod common;
use common::{check_closed_manifold, Sdf};
use volga_mesh::{
    extract_surface_with, point_triangle_distance_squared, ExtractMethod, Extraction, IsoIndex, Surface, TriMesh,
};

/// Values on the integer lattice `0..n`, trilinear between (a density-like field: inside is
/// `≥ iso`). Points outside the lattice read `outside`.
struct Lattice3 {
    n: IVec3,
    values: Vec<f64>,
    outside: f64,
}

impl Lattice3 {
    fn get(&self, p: IVec3) -> f64 {
        if p.cmplt(IVec3::ZERO).any() || p.cmpge(self.n).any() {
            return self.outside;
        }
        self.values[(p.x + self.n.x * (p.y + self.n.y * p.z)) as usize]
    }
}

impl Field for Lattice3 {
    fn kind(&self) -> FieldKind {
        FieldKind::Density
    }
    fn bounds(&self) -> Aabb {
        Aabb::new(DVec3::ZERO, (self.n - 1).as_dvec3())
    }
    fn value(&self, p: DVec3) -> f64 {
        let f = p.floor();
        let i = f.as_ivec3();
        let t = p - f;
        let mut v = 0.0;
        for c in 0..8 {
            let o = IVec3::new(c & 1, c >> 1 & 1, c >> 2 & 1);
            let w = (if o.x == 1 { t.x } else { 1.0 - t.x })
                * (if o.y == 1 { t.y } else { 1.0 - t.y })
                * (if o.z == 1 { t.z } else { 1.0 - t.z });
            if w != 0.0 {
                v += w * self.get(i + o);
            }
        }
        v
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(1e-6)
    }
    fn value_range(&self, _: &Aabb) -> (f64, f64) {
        let (lo, hi) = self
            .values
            .iter()
            .fold((self.outside, self.outside), |(a, b), &v| (a.min(v), b.max(v)));
        (lo, hi)
    }
}

/// A small deterministic generator (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn signed_volume(mesh: &TriMesh) -> f64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

fn euler(mesh: &TriMesh) -> i64 {
    let mut edges: Vec<(u32, u32)> = mesh
        .triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]))))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    mesh.positions.len() as i64 - edges.len() as i64 + mesh.triangles.len() as i64
}

fn job(region: Aabb, cell: f64, iso: f64, method: ExtractMethod) -> Extraction {
    Extraction::new(region, cell, iso).with_method(method)
}

fn random_lattice(rng: &mut Rng, n: i32, ties: bool) -> Lattice3 {
    let count = (n * n * n) as usize;
    let values = (0..count)
        .map(|_| {
            if ties {
                // −1, 0 or 1: many values exactly at the iso-value 0.
                (rng.next() % 3) as f64 - 1.0
            } else {
                rng.unit() * 2.0 - 1.0
            }
        })
        .collect();
    Lattice3 {
        n: IVec3::splat(n),
        values,
        outside: -1.0,
    }
}

#[test]
fn random_lattices_are_closed_and_manifold_for_every_method() {
    let mut rng = Rng(7);
    let mut tubes = 0;
    let mut triangles = [0usize; 3];
    for case in 0..400 {
        let ties = case % 4 == 3;
        let field = random_lattice(&mut rng, 6, ties);
        // One lattice point of margin (read as outside) closes every surface.
        let region = Aabb::new(DVec3::splat(-1.0), DVec3::splat(6.0));
        for (m, method) in ExtractMethod::ALL.into_iter().enumerate() {
            let s = extract_surface_with(&field, &job(region, 1.0, 0.0, method)).unwrap();
            if s.mesh.triangles.is_empty() {
                continue;
            }
            let what = format!(
                "case {case} ({}), {}",
                if ties { "ties" } else { "random" },
                method.name()
            );
            check_closed_manifold(&s.mesh, &what);
            triangles[m] += s.mesh.triangles.len();
            if method == ExtractMethod::Cubes {
                tubes += s.tubes;
                assert!(signed_volume(&s.mesh) > 0.0, "{what}: not outward");
            }
        }
    }
    assert!(tubes > 20, "the interior test joined only {tubes} tubes");
    // Marching cubes: about a third of the tetrahedra's triangles.
    let ratio = triangles[1] as f64 / triangles[0] as f64;
    assert!(ratio < 0.5, "cubes/tetrahedra triangle ratio {ratio}");
}

/// The trilinear interpolant of one cube, its topology (Euler characteristic of the open
/// surface in the cube) from marching cubes against marching tetrahedra on a fine lattice
/// of the same interpolant, where that reference is unambiguous (two fine lattices agree).
#[test]
fn one_cube_topology_matches_the_trilinear_interpolant() {
    let mut rng = Rng(11);
    let (mut compared, mut tunnels_compared) = (0, 0);
    for case in 0..1500 {
        let mut values: Vec<f64> = (0..8).map(|_| rng.unit() * 2.0 - 1.0).collect();
        // Bias half the cases toward the tunnel configurations (two opposite corners in).
        if case % 2 == 0 {
            for (c, v) in values.iter_mut().enumerate() {
                let inside = c == 0 || c == 7 || (case % 4 == 0 && c == 3);
                *v = if inside { v.abs() } else { -v.abs() * 0.6 };
            }
        }
        let field = Lattice3 {
            n: IVec3::splat(2),
            values,
            outside: 0.0,
        };
        let region = Aabb::new(DVec3::ZERO, DVec3::ONE);
        let cubes = extract_surface_with(&field, &job(region, 1.0, 0.0, ExtractMethod::Cubes)).unwrap();
        if cubes.mesh.triangles.is_empty() {
            continue;
        }
        let fine = |k: f64| {
            let s = extract_surface_with(&field, &job(region, 1.0 / k, 0.0, ExtractMethod::Tetrahedra)).unwrap();
            euler(&s.mesh)
        };
        let (a, b) = (fine(20.0), fine(27.0));
        if a != b {
            continue; // a feature near the fine lattice's resolution: no clear reference
        }
        assert_eq!(euler(&cubes.mesh), a, "case {case}: {:?}", field.values);
        compared += 1;
        tunnels_compared += cubes.tubes as usize;
    }
    assert!(
        compared > 1000 && tunnels_compared > 25,
        "{compared} compared, {tunnels_compared} tunnels"
    );
}

/// The exact distance of a box of half-sizes `h` rotated by `rot` about `c`.
/// The box the sharp-edge tests use: centre, half-sizes and rotation (off every lattice
/// plane and axis).
fn rotated_box() -> (DVec3, DVec3, glam::DQuat) {
    (
        DVec3::new(0.13, -0.07, 0.21),
        DVec3::new(2.0, 1.3, 1.7),
        glam::DQuat::from_euler(glam::EulerRot::XYZ, 0.3, 0.5, 0.2),
    )
}

fn box_sdf(c: DVec3, h: DVec3, rot: glam::DQuat) -> impl Fn(DVec3) -> f64 + Sync {
    move |p: DVec3| {
        let q = (rot.inverse() * (p - c)).abs() - h;
        q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
    }
}

fn distance_to_mesh(p: DVec3, mesh: &TriMesh) -> f64 {
    (0..mesh.triangle_count())
        .map(|t| point_triangle_distance_squared(p, mesh.triangle(t)))
        .fold(f64::INFINITY, f64::min)
        .sqrt()
}

#[test]
fn dual_contouring_keeps_a_rotated_box_sharp_and_cubes_chamfer_it() {
    let (c, h, rot) = rotated_box();
    let f = box_sdf(c, h, rot);
    let field = Sdf(&f, Aabb::new(DVec3::splat(-4.0), DVec3::splat(4.0)));
    let region = Aabb::new(DVec3::splat(-3.6), DVec3::splat(3.6));
    let cell = 0.2;
    // Points along the box's 12 edges (away from the corners).
    let mut edge_points = Vec::new();
    for axis in 0..3 {
        for s in 0..4 {
            let mut o = DVec3::ZERO;
            let (b, d) = ((axis + 1) % 3, (axis + 2) % 3);
            o[b] = if s & 1 == 1 { h[b] } else { -h[b] };
            o[d] = if s & 2 == 2 { h[d] } else { -h[d] };
            for k in 1..8 {
                let mut p = o;
                p[axis] = -h[axis] + 2.0 * h[axis] * k as f64 / 8.0;
                edge_points.push(c + rot * p);
            }
        }
    }
    let mut worst = [0.0; 2];
    for (i, method) in [ExtractMethod::Cubes, ExtractMethod::Dual].into_iter().enumerate() {
        let s = extract_surface_with(&field, &job(region, cell, 0.0, method)).unwrap();
        check_closed_manifold(&s.mesh, method.name());
        assert_eq!(euler(&s.mesh), 2);
        worst[i] = edge_points
            .iter()
            .map(|&p| distance_to_mesh(p, &s.mesh))
            .fold(0.0, f64::max);
        if method == ExtractMethod::Dual {
            // Every vertex on the box (planes meeting at edges and corners are solved exactly).
            for p in &s.mesh.positions {
                assert!(f(*p).abs() < 0.02 * cell, "dual vertex {p} off the box by {}", f(*p));
            }
        }
    }
    // Marching cubes cut the edges (a chamfer of order a cell); dual contouring keeps them.
    assert!(worst[0] > 0.1 * cell, "cubes edge error {}", worst[0]);
    assert!(
        worst[1] < 0.5 * worst[0] && worst[1] < 0.1 * cell,
        "dual edge error {} (cubes {})",
        worst[1],
        worst[0]
    );
}

#[test]
fn adaptivity_cuts_flat_regions_within_its_bound_and_stays_manifold() {
    let (c, h, rot) = rotated_box();
    let f = box_sdf(c, h, rot);
    let field = Sdf(&f, Aabb::new(DVec3::splat(-4.0), DVec3::splat(4.0)));
    let region = Aabb::new(DVec3::splat(-3.6), DVec3::splat(3.6));
    let cell = 0.2;
    for method in ExtractMethod::ALL {
        let full = extract_surface_with(&field, &job(region, cell, 0.0, method)).unwrap();
        let eps = 0.1;
        let adaptive = extract_surface_with(&field, &job(region, cell, 0.0, method).with_adaptivity(eps)).unwrap();
        let what = format!("{} adaptivity {eps}", method.name());
        check_closed_manifold(&adaptive.mesh, &what);
        assert_eq!(euler(&adaptive.mesh), 2, "{what}");
        assert!(
            adaptive.mesh.triangles.len() * 4 < full.mesh.triangles.len(),
            "{what}: {} of {} triangles",
            adaptive.mesh.triangles.len(),
            full.mesh.triangles.len()
        );
        // Every vertex within the bound of the surface (the box's faces are the planes).
        let worst = adaptive.mesh.positions.iter().map(|p| f(*p).abs()).fold(0.0, f64::max);
        let base = full.mesh.positions.iter().map(|p| f(*p).abs()).fold(0.0, f64::max);
        assert!(
            worst <= base + eps * cell + 1e-9,
            "{what}: vertex off by {worst} (unsimplified {base})"
        );
    }
}

#[test]
fn sphere_and_torus_vertices_lie_near_the_surface_for_every_method() {
    let torus = |p: DVec3| glam::DVec2::new(glam::DVec2::new(p.x, p.y).length() - 3.0, p.z).length() - 1.1;
    let sphere = |p: DVec3| (p - DVec3::new(0.1, 0.2, -0.3)).length() - 3.3;
    type Shape<'a> = &'a (dyn Fn(DVec3) -> f64 + Sync);
    let shapes: [(&str, Shape, i64); 2] = [("torus", &torus, 0), ("sphere", &sphere, 2)];
    for (name, f, chi) in shapes {
        let field = Sdf(f, Aabb::new(DVec3::splat(-5.0), DVec3::splat(5.0)));
        let region = Aabb::new(DVec3::splat(-4.6), DVec3::splat(4.6));
        let cell = 0.23;
        for method in ExtractMethod::ALL {
            let s = extract_surface_with(&field, &job(region, cell, 0.0, method)).unwrap();
            let what = format!("{name} {}", method.name());
            check_closed_manifold(&s.mesh, &what);
            assert_eq!(euler(&s.mesh), chi, "{what}");
            let worst = s.mesh.positions.iter().map(|p| f(*p).abs()).fold(0.0, f64::max);
            let bound = match method {
                ExtractMethod::Dual => 0.05 * cell,
                _ => 1e-8,
            };
            assert!(worst <= bound, "{what}: vertex {worst} from the surface");
            for (p, n) in s.mesh.positions.iter().zip(&s.normals) {
                assert!((n.length() - 1.0).abs() < 1e-9, "{what}: normal at {p}");
            }
        }
    }
}

#[test]
fn the_same_mesh_for_one_and_two_threads_far_from_the_origin() {
    let c = DVec3::new(1e6, -1e6, 1e6);
    let f = box_sdf(c, DVec3::new(1.0, 1.4, 0.8), glam::DQuat::from_rotation_y(0.4));
    let field = Sdf(&f, Aabb::new(c - 3.0, c + 3.0));
    let region = Aabb::new(c - 2.5, c + 2.5);
    for method in ExtractMethod::ALL {
        let run = |threads: usize| -> Surface {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    extract_surface_with(&field, &job(region, 0.07, 0.0, method).with_adaptivity(0.05)).unwrap()
                })
        };
        let (one, two) = (run(1), run(2));
        assert_eq!(one, two, "{}", method.name());
        check_closed_manifold(&one.mesh, method.name());
    }
}

#[test]
fn the_iso_index_re_extracts_what_a_fresh_extraction_gives() {
    let f = |p: DVec3| (p.length() - 2.0) + 0.3 * (3.0 * p.x).sin() * (2.0 * p.y).cos();
    let field = Sdf(&f, Aabb::new(DVec3::splat(-4.0), DVec3::splat(4.0)));
    let region = Aabb::new(DVec3::splat(-3.9), DVec3::splat(3.9));
    for method in ExtractMethod::ALL {
        let base = job(region, 0.13, 0.0, method);
        let index = IsoIndex::build(&field, &base, (-0.6, 0.6), 1 << 30).unwrap();
        for iso in [-0.5, -0.1, 0.0, 0.35] {
            let fresh = extract_surface_with(&field, &Extraction { iso, ..base }).unwrap();
            let again = index.extract(iso).unwrap();
            assert_eq!(fresh.mesh, again.mesh, "{} at {iso}", method.name());
            assert!(index.candidates(iso) < index.blocks() || iso == 0.0);
        }
        assert!(matches!(
            IsoIndex::build(&field, &base, (-0.6, 0.6), 1000),
            Err(volga_mesh::ExtractError::IndexTooLarge { .. })
        ));
    }
}
