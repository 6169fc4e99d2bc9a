//! Mesh extraction: each method (marching tetrahedra, marching cubes, dual contouring) and
//! adaptivity, on exact signed distances (sphere, torus, rounded box, a box with sharp
//! edges, and fandisk's exact mesh distance), against the exact surface.
//!
//! * **Distances to the surface**: `|d|` of the exact signed distance at every vertex and at
//!   four points per triangle (centroid and the points halfway from it to each corner),
//!   in lattice cells; the **Hausdorff distance** is the larger of their maximum and the
//!   maximum over points on the exact surface (lattice points projected onto it by three
//!   Newton steps along the exact gradient) of their distance to the mesh.
//! * **Normal error**: each triangle's normal against the exact gradient at its centroid,
//!   RMS weighted by area.
//! * **Sharp-edge error**: points every quarter cell along the box's twelve edges, or along
//!   fandisk's edges sharper than 30°, to the mesh (the chamfer a marching method cuts).

use glam::DVec3;
use rayon::prelude::*;
use volga_core::{Aabb, Field};
use volga_mesh::{Bvh, ExtractMethod, Extraction, MeshQueries, TriMesh};
use volga_shapes::{DistanceField, SignedDistance};

use super::{Context, Experiment};
use crate::references::{ReferenceShape, RoundedBox};
use crate::{timed, KnobResult, Metric, Series, Setting};

pub const EXPERIMENT: Experiment = Experiment { id: "extraction", run };

/// The settings: method and adaptivity (cells).
const SETTINGS: [(ExtractMethod, f64); 5] = [
    (ExtractMethod::Tetrahedra, 0.0),
    (ExtractMethod::Cubes, 0.0),
    (ExtractMethod::Dual, 0.0),
    (ExtractMethod::Cubes, 0.25),
    (ExtractMethod::Dual, 0.25),
];

/// An exact signed distance and what the errors need of it.
trait Exact: Sync {
    fn distance(&self, p: DVec3) -> f64;
    fn gradient(&self, p: DVec3) -> DVec3;
}

impl<S: SignedDistance + Sync> Exact for S {
    fn distance(&self, p: DVec3) -> f64 {
        self.signed_distance(p)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        SignedDistance::gradient(self, p).normalize_or_zero()
    }
}

/// A mesh's exact signed distance (nearest triangle, certified winding-number sign).
struct MeshDistance {
    queries: MeshQueries,
    bounds: Aabb,
}

impl Field for MeshDistance {
    fn kind(&self) -> volga_core::FieldKind {
        volga_core::FieldKind::SignedDistance
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn value(&self, p: DVec3) -> f64 {
        self.queries.signed_distance(p)
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(1e-6 * self.bounds.size().max_element())
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        let d = self.value(b.center());
        let h = 0.5 * b.size().length();
        (d - h, d + h)
    }
}

impl Exact for MeshDistance {
    fn distance(&self, p: DVec3) -> f64 {
        self.queries.signed_distance(p)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        Field::gradient(self, p).normalize_or_zero()
    }
}

/// One shape's curve: every setting extracted over `region` at `cell`, measured.
fn series<F: Field, E: Exact>(
    name: &str,
    field: &F,
    exact: &E,
    region: Aabb,
    cell: f64,
    sharp: &[DVec3],
    ctx: &Context,
) -> Series {
    // Points on the exact surface: lattice points within two cells of it, projected.
    let n = (region.size() / cell).ceil().as_ivec3();
    let mut on_surface = Vec::new();
    for z in 0..=n.z {
        for y in 0..=n.y {
            for x in 0..=n.x {
                let p = region.min + DVec3::new(x as f64, y as f64, z as f64) * cell;
                if exact.distance(p).abs() < 2.0 * cell {
                    on_surface.push(p);
                }
            }
        }
    }
    let on_surface: Vec<DVec3> = on_surface
        .into_par_iter()
        .map(|mut p| {
            for _ in 0..3 {
                p -= exact.gradient(p) * exact.distance(p);
            }
            p
        })
        .filter(|p| exact.distance(*p).abs() < 1e-6 * cell)
        .collect();
    let settings = SETTINGS
        .iter()
        .map(|&(method, adaptivity)| {
            let job = Extraction::new(region, cell, 0.0)
                .with_method(method)
                .with_adaptivity(adaptivity);
            let (surface, timing) = timed(|| volga_mesh::extract_surface_with(field, &job).expect("extraction"));
            let mesh = &surface.mesh;
            let e = errors(mesh, exact, cell, &on_surface, sharp);
            ctx.setting_done();
            let label = if adaptivity > 0.0 {
                format!("{} a={adaptivity}", method.name())
            } else {
                method.name().to_string()
            };
            let bytes = (mesh.positions.len() * 24 + mesh.triangles.len() * 12 + surface.normals.len() * 24) as u64;
            Setting::new(label, &[("adaptivity", adaptivity)], timing, bytes)
                .error("vertex_max", e.vertex_max)
                .error("sample_rms", e.sample_rms)
                .error("hausdorff", e.hausdorff)
                .error("normal_rms_deg", e.normal_rms_deg)
                .error("sharp_edge_max", e.sharp_max)
                .error("triangles", mesh.triangles.len() as f64)
        })
        .collect();
    Series {
        name: name.to_string(),
        settings,
    }
}

struct Errors {
    vertex_max: f64,
    sample_rms: f64,
    hausdorff: f64,
    normal_rms_deg: f64,
    sharp_max: f64,
}

fn errors<E: Exact>(mesh: &TriMesh, exact: &E, cell: f64, on_surface: &[DVec3], sharp: &[DVec3]) -> Errors {
    let vertex_max = mesh
        .positions
        .par_iter()
        .map(|p| exact.distance(*p).abs())
        .reduce(|| 0.0, f64::max)
        / cell;
    let samples: Vec<f64> = mesh
        .triangles
        .par_iter()
        .flat_map_iter(|t| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            let m = (a + b + c) / 3.0;
            [m, 0.5 * (m + a), 0.5 * (m + b), 0.5 * (m + c)].map(|p| exact.distance(p).abs() / cell)
        })
        .collect();
    // Area-weighted, so a few large flat triangles count for the surface they cover.
    let normals: Vec<(f64, f64)> = mesh
        .triangles
        .par_iter()
        .filter_map(|t| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            let cross = (b - a).cross(c - a);
            let n = cross.normalize_or_zero();
            let g = exact.gradient((a + b + c) / 3.0);
            (n != DVec3::ZERO && g != DVec3::ZERO)
                .then(|| (n.dot(g).clamp(-1.0, 1.0).acos().to_degrees(), cross.length()))
        })
        .collect();
    let area: f64 = normals.iter().map(|(_, w)| w).sum();
    let bvh = Bvh::build(mesh);
    let to_mesh = |pts: &[DVec3]| {
        pts.par_iter()
            .map(|&p| bvh.closest(p).map_or(f64::INFINITY, |c| c.distance) / cell)
            .reduce(|| 0.0, f64::max)
    };
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
    let sample_max = samples.iter().copied().fold(0.0, f64::max);
    Errors {
        vertex_max,
        sample_rms: rms(&samples),
        hausdorff: sample_max.max(vertex_max).max(to_mesh(on_surface)),
        normal_rms_deg: (normals.iter().map(|(d, w)| d * d * w).sum::<f64>() / area.max(f64::MIN_POSITIVE)).sqrt(),
        sharp_max: to_mesh(sharp),
    }
}

/// Points every quarter cell along the edges of the box `c ± h`.
fn box_edges(c: DVec3, h: DVec3, cell: f64) -> Vec<DVec3> {
    let mut out = Vec::new();
    for axis in 0..3 {
        let (b, d) = ((axis + 1) % 3, (axis + 2) % 3);
        for s in 0..4 {
            let mut o = c;
            o[b] += if s & 1 == 1 { h[b] } else { -h[b] };
            o[d] += if s & 2 == 2 { h[d] } else { -h[d] };
            let steps = (2.0 * h[axis] / (0.25 * cell)).ceil() as usize;
            for k in 0..=steps {
                let mut p = o;
                p[axis] = c[axis] - h[axis] + 2.0 * h[axis] * k as f64 / steps as f64;
                out.push(p);
            }
        }
    }
    out
}

fn run(ctx: &Context) -> KnobResult {
    let n = ctx.size.pick(20.0, 64.0);
    let region = crate::references::scene_box();
    let cell = region.size().x / n;
    let shapes: Vec<(ReferenceShape, &str)> = match ctx.size {
        crate::experiments::Size::Quick => vec![(ReferenceShape::sphere(), "sphere")],
        crate::experiments::Size::Full => vec![
            (ReferenceShape::sphere(), "sphere"),
            (ReferenceShape::torus(), "torus"),
            (ReferenceShape::rounded_box(), "rounded box"),
        ],
    };
    let full = ctx.size == crate::experiments::Size::Full;
    ctx.start("extraction", SETTINGS.len() * (shapes.len() + 1 + full as usize));
    let mut out = Vec::new();
    for (shape, name) in shapes {
        let field = DistanceField::new(shape, 0.1, 1e-6);
        out.push(series(name, &field, &shape, region, cell, &[], ctx));
    }
    // A box with sharp edges and corners (its faces off the lattice planes).
    let sharp_box = RoundedBox {
        center: DVec3::new(0.031, -0.017, 0.023),
        half_extents: DVec3::new(0.6, 0.45, 0.35),
        radius: 0.0,
    };
    let field = DistanceField::new(sharp_box, 0.1, 1e-6);
    let edges = box_edges(sharp_box.center, sharp_box.half_extents, cell);
    out.push(series(
        "box (sharp edges)",
        &field,
        &sharp_box,
        region,
        cell,
        &edges,
        ctx,
    ));
    if full {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/fandisk.obj");
        let mesh = volga_mesh::load_mesh(path).unwrap_or_else(|e| panic!("{path}: {e}"));
        let b = mesh.bounds();
        let cell = b.size().max_element() / n;
        let region = Aabb::new(b.min - 2.0 * cell, b.max + 2.0 * cell);
        let exact = MeshDistance {
            queries: MeshQueries::new(&mesh),
            bounds: region,
        };
        let edges = mesh.sharp_edge_points(30.0, 0.25 * cell);
        out.push(series(
            "fandisk (exact mesh distance)",
            &exact,
            &exact,
            region,
            cell,
            &edges,
            ctx,
        ));
    }
    ctx.finish();
    KnobResult {
        id: "extraction",
        title: "Mesh extraction: method and adaptivity against surface error",
        knob: "extraction method (tetrahedra, cubes, dual) and adaptivity in cells (a=…), on a lattice of 64 cells across the scene box (fandisk: across its box)",
        reference: "the exact signed distance (analytic shapes; fandisk: nearest triangle with the certified winding-number sign) at vertices, triangle points and projected surface points; exact gradients for normals; points along the sharp edges",
        timed: "extract_surface_with on the exact distance field, vertices refined onto the surface (1e-9), all threads",
        metrics: vec![
            Metric { id: "hausdorff", label: "Hausdorff distance to the exact surface (cells)" },
            Metric { id: "sample_rms", label: "triangle points' distance, RMS (cells)" },
            Metric { id: "vertex_max", label: "vertex distance, max (cells)" },
            Metric { id: "normal_rms_deg", label: "face normal error, area-weighted RMS (degrees)" },
            Metric { id: "sharp_edge_max", label: "sharp-edge points to the mesh, max (cells; 0: no sharp edges)" },
            Metric { id: "triangles", label: "triangles" },
        ],
        series: out,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_of_an_exact_octahedron_are_zero_and_of_a_shifted_one_are_the_shift() {
        // The L1 ball |x|+|y|+|z| = 1 is an octahedron; its triangles lie on the surface.
        struct L1;
        impl Exact for L1 {
            fn distance(&self, p: DVec3) -> f64 {
                (p.x.abs() + p.y.abs() + p.z.abs() - 1.0) / 3f64.sqrt()
            }
            fn gradient(&self, p: DVec3) -> DVec3 {
                DVec3::new(p.x.signum(), p.y.signum(), p.z.signum()) / 3f64.sqrt()
            }
        }
        let positions = vec![DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X, -DVec3::Y, -DVec3::Z];
        let triangles = vec![
            [0, 1, 2],
            [1, 3, 2],
            [3, 4, 2],
            [4, 0, 2],
            [1, 0, 5],
            [3, 1, 5],
            [4, 3, 5],
            [0, 4, 5],
        ];
        let mesh = TriMesh::new(positions.clone(), triangles.clone()).unwrap();
        let e = errors(&mesh, &L1, 0.1, &[DVec3::splat(1.0 / 3.0)], &[DVec3::X]);
        assert!(e.vertex_max < 1e-12 && e.hausdorff < 1e-12 && e.sharp_max < 1e-12);
        assert!(e.normal_rms_deg < 1e-6);
        let grown = TriMesh::new(positions.iter().map(|p| *p * 1.3).collect(), triangles).unwrap();
        let e = errors(&grown, &L1, 0.1, &[], &[]);
        // Vertices moved 0.3 outward along the axes: |d| = 0.3/√3, in cells of 0.1.
        assert!((e.vertex_max - 3.0 / 3f64.sqrt()).abs() < 1e-9, "{}", e.vertex_max);
    }
}
