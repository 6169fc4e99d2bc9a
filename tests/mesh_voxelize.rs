//! Mesh voxelization against exact references: narrow-band distances equal a brute-force
//! point–triangle minimum, signs equal the exact generalized winding number (≥ ½ inside),
//! on a closed mesh (spot), an open scan (the Stanford bunny) and random small meshes.

use glam::{DVec3, UVec3};
use proptest::prelude::*;
use volga::mesh::{point_triangle_distance_squared, Bvh, TriMesh};
use volga::voxelize::{MeshVoxelizer, SurfaceMode};
use volga::{Aabb, Grid, NoProgress, Transform};

/// A mesh vendored in tests/data (see its README for provenance and licences).
fn shared(name: &str) -> TriMesh {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    volga::mesh::load_obj(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A grid with `n` voxels along the mesh's longest side, padded by 4 voxels.
fn grid_for(bounds: Aabb, n: u32) -> Grid {
    let h = bounds.size().max_element() / n as f64;
    let dims = (bounds.size() / h).ceil().as_uvec3() + UVec3::splat(8);
    Grid::new(
        Transform::new(bounds.min - 4.0 * h + 0.5 * h, glam::DVec3::splat(h)).unwrap(),
        dims,
    )
    .unwrap()
}

fn brute_distance(mesh: &TriMesh, p: DVec3) -> f64 {
    (0..mesh.triangles.len())
        .map(|i| point_triangle_distance_squared(p, mesh.triangle(i)))
        .fold(f64::INFINITY, f64::min)
        .sqrt()
}

/// Checks band voxels (every `stride`-th, at most 1500) against brute force, and every
/// other voxel against the BVH's exact nearest distance. Returns (checked, wrong signs,
/// max |distance error| in voxels).
fn check(mesh: &TriMesh, n: u32, stride: usize) -> (usize, usize, f64) {
    let grid = grid_for(mesh.bounds(), n);
    let h = grid.transform.spacing().x;
    let vox = MeshVoxelizer::new(mesh);
    let v = vox.voxelize(
        &grid,
        SurfaceMode::Distance {
            half_width_voxels: 3.0,
            signed: true,
        },
        &NoProgress,
    );
    let bvh = Bvh::build(mesh);
    let band = 3.0 * h;
    let (mut checked, mut wrong, mut worst, mut seen) = (0, 0, 0.0f64, 0usize);
    for ijk in grid.index_box().iter() {
        let p = grid.transform.voxel_center(ijk);
        let value = v.density.get(ijk) as f64;
        let nearest = bvh.closest(p).unwrap().distance;
        if nearest >= band * 0.999 {
            assert!(
                value.abs() >= band * 0.999 - 1e-6,
                "{ijk}: {value} inside the band but nearest {nearest}"
            );
            continue;
        }
        seen += 1;
        if seen % stride != 0 || checked >= 1500 {
            continue;
        }
        checked += 1;
        let exact = brute_distance(mesh, p);
        worst = worst.max((value.abs() - exact).abs() / h);
        let w = bvh.winding_number_exact(p);
        // On the surface (distance 0) either sign is right.
        if exact > 0.0 && (w - 0.5).abs() > 0.01 && ((w >= 0.5) != (value < 0.0)) {
            eprintln!("wrong sign at {ijk}: value {value}, exact distance {exact}, w {w}");
            wrong += 1;
        }
    }
    (checked, wrong, worst)
}

#[test]
fn closed_mesh_band_is_exact() {
    let spot = shared("spot.obj");
    let (checked, wrong, worst) = check(&spot, 40, 2);
    assert!(checked >= 1000, "{checked}");
    assert_eq!(wrong, 0);
    // f32 payload: distances to a few ulps.
    assert!(worst < 1e-5, "{worst}");
}

#[test]
fn open_bunny_band_signs_follow_the_winding_number() {
    let bunny = shared("stanford-bunny.obj");
    let vox = MeshVoxelizer::new(&bunny);
    assert_eq!(vox.boundary_edge_count(), 223);
    let (checked, wrong, worst) = check(&bunny, 32, 2);
    assert!(checked >= 1000, "{checked}");
    assert_eq!(wrong, 0, "{wrong} of {checked} band voxels have the wrong sign");
    assert!(worst < 1e-5, "{worst}");
}

fn tetra() -> impl Strategy<Value = TriMesh> {
    let p = (-4.0f64..4.0, -4.0f64..4.0, -4.0f64..4.0).prop_map(|(x, y, z)| DVec3::new(x, y, z));
    (p.clone(), p.clone(), p.clone(), p).prop_filter_map("flat", |(a, b, c, d)| {
        let vol = (b - a).cross(c - a).dot(d - a);
        if vol.abs() < 1.0 {
            return None;
        }
        // Outward orientation.
        let (b, c) = if vol > 0.0 { (c, b) } else { (b, c) };
        TriMesh::new(vec![a, b, c, d], vec![[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]]).ok()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]
    #[test]
    fn random_tetrahedra_distance_and_sign(mesh in tetra(), offset in prop_oneof![Just(0.0), Just(1e6)]) {
        let mesh = mesh.translated(DVec3::splat(offset));
        let (checked, wrong, worst) = check(&mesh, 12, 1);
        prop_assert!(checked > 0);
        prop_assert_eq!(wrong, 0);
        // Far from the origin the f32 payload still resolves the distance (the world
        // coordinates are f64; distances are small numbers).
        prop_assert!(worst < 1e-4, "{}", worst);
    }
}

#[test]
fn anti_aliased_solid_of_closed_mesh_has_its_volume() {
    let spot = shared("spot.obj");
    // Exact volume by the divergence theorem.
    let exact: f64 = (0..spot.triangles.len())
        .map(|i| {
            let [a, b, c] = spot.triangle(i);
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    let grid = grid_for(spot.bounds(), 96);
    let v = MeshVoxelizer::new(&spot).voxelize(&grid, SurfaceMode::Solid, &NoProgress);
    let rel = volga::voxelize::measure::occupied_volume(&v) / exact - 1.0;
    assert!(rel.abs() < 1e-2, "{rel}");
}

#[test]
fn mesh_voxelization_is_deterministic_and_finite() {
    let bunny = shared("stanford-bunny.obj");
    let grid = grid_for(bunny.bounds(), 48);
    let vox = MeshVoxelizer::new(&bunny);
    for mode in [
        SurfaceMode::Solid,
        SurfaceMode::Shell {
            thickness: grid.transform.spacing().x,
        },
        SurfaceMode::Distance {
            half_width_voxels: 2.5,
            signed: true,
        },
    ] {
        let run = |n| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
                .install(|| vox.voxelize(&grid, mode, &NoProgress).to_dense().unwrap())
        };
        let one = run(1);
        assert!(one.density.as_slice().iter().all(|v| v.is_finite()), "{mode:?}");
        assert_eq!(one, run(2), "{mode:?}");
    }
}

/// Beyond the band the sign must still be the winding number's, also round the rim of
/// an open mesh, where the region beyond the band joins the inside and the outside
/// without crossing the surface (a flood fill from band voxels alone would let either
/// side leak through the opening). A box without its top face: every brick of the grid
/// is reached by some wall's band, so every voxel is decided brick by brick.
#[test]
fn open_box_signs_beyond_the_band_follow_the_winding_number() {
    let closed = TriMesh::from_aabb(&Aabb::new(DVec3::splat(6.0), DVec3::splat(26.0)));
    let mut open = closed.clone();
    open.triangles.drain(2..4); // the z = hi face
    let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), glam::UVec3::splat(32)).unwrap();
    let v = MeshVoxelizer::new(&open).voxelize(
        &grid,
        SurfaceMode::Distance {
            half_width_voxels: 3.0,
            signed: true,
        },
        &NoProgress,
    );
    let bvh = Bvh::build(&open);
    let (mut checked, mut wrong) = (0, 0);
    for ijk in grid.index_box().iter() {
        let p = grid.transform.voxel_center(ijk);
        let w = bvh.winding_number_exact(p);
        if (w - 0.5).abs() < 0.05 || bvh.closest(p).unwrap().distance < 3.0 {
            continue;
        }
        checked += 1;
        if (w >= 0.5) != (v.density.get(ijk) < 0.0) {
            wrong += 1;
        }
    }
    assert!(checked > 20_000, "{checked}");
    assert_eq!(
        wrong, 0,
        "{wrong} of {checked} voxels beyond the band have the wrong sign"
    );
}

/// Triangle soups from a small vertex pool: shared edges and vertices, non-manifold
/// fans, repeated corners (degenerate triangles), slivers and vertices on voxel centres.
/// Every band voxel's distance must equal brute force: the feature regions that limit
/// where each triangle is evaluated must cover every voxel's nearest feature.
fn soup() -> impl Strategy<Value = TriMesh> {
    let coord = prop_oneof![(-40i32..40).prop_map(|c| c as f64 * 0.1), -4.0f64..4.0];
    let p = (coord.clone(), coord.clone(), coord).prop_map(|(x, y, z)| DVec3::new(x, y, z));
    (
        prop::collection::vec(p, 3..7),
        prop::collection::vec((0u32..7, 0u32..7, 0u32..7), 1..10),
        0.0f64..1e-9,
    )
        .prop_filter_map("indices", |(mut pool, tris, sliver)| {
            // A sliver: the last vertex nudged off the midpoint of the first two.
            let n = pool.len();
            pool.push((pool[0] + pool[1]) * 0.5 + DVec3::splat(sliver));
            let tris: Vec<[u32; 3]> = tris
                .into_iter()
                .map(|(a, b, c)| [a % (n as u32 + 1), b % (n as u32 + 1), c % (n as u32 + 1)])
                .collect();
            TriMesh::new(pool, tris).ok()
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn triangle_soup_distances_are_exact(mesh in soup(), offset in prop_oneof![Just(0.0), Just(1e6)]) {
        // A soup collapsed to a point or a tiny cluster has no grid of 14 voxels.
        prop_assume!(mesh.bounds().size().max_element() > 1e-6);
        let mesh = mesh.translated(DVec3::splat(offset));
        let grid = grid_for(mesh.bounds(), 14);
        let h = grid.transform.spacing().x;
        let v = MeshVoxelizer::new(&mesh).voxelize(
            &grid,
            SurfaceMode::Distance { half_width_voxels: 2.5, signed: false },
            &NoProgress,
        );
        let band = 2.5 * h;
        for ijk in grid.index_box().iter() {
            let exact = brute_distance(&mesh, grid.transform.voxel_center(ijk));
            let value = v.density.get(ijk) as f64;
            if exact < band * 0.999 {
                prop_assert!((value - exact).abs() <= 1e-5 * h, "{}: {} vs exact {}", ijk, value, exact);
            } else {
                prop_assert!(value >= band * 0.999 - 1e-6 * h, "{}: {} outside the band (exact {})", ijk, value, exact);
            }
        }
    }
}

/// A sliver 1e-9 wide (found by the soup proptest): Ericson's barycentric form cancels
/// catastrophically inside it and gave distances 1 % too large; thin triangles now take
/// the plane inside and the edges outside.
#[test]
fn sliver_distances_are_exact() {
    let s = 9.95455286094981e-10;
    let mesh = TriMesh::new(
        vec![DVec3::new(0.0, 0.0, -0.1), DVec3::splat(s), DVec3::ZERO],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let grid = grid_for(mesh.bounds(), 14);
    let h = grid.transform.spacing().x;
    let v = MeshVoxelizer::new(&mesh).voxelize(
        &grid,
        SurfaceMode::Distance {
            half_width_voxels: 2.5,
            signed: false,
        },
        &NoProgress,
    );
    for ijk in grid.index_box().iter() {
        let exact = brute_distance(&mesh, grid.transform.voxel_center(ijk));
        if exact < 2.5 * h * 0.999 {
            let value = v.density.get(ijk) as f64;
            assert!((value - exact).abs() <= 1e-5 * h, "{ijk}: {value} vs exact {exact}");
        }
    }
}
