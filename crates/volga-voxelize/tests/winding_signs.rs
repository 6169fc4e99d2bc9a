//! Inside means generalized winding number ≥ ½, on every mesh: the signs of the three
//! modes that use them (signed distance, anti-aliased solid, binary inside) against a
//! brute-force float64 winding number, at every voxel of the distance band and at random
//! voxels of the whole grid. The meshes are the unclean corpus (self-intersecting,
//! overlapping, nested, flipped, open, flat, stacked, single triangles and quads, far
//! from the origin), the teapot and the bunny, random triangle soups, and grids whose
//! voxel centres lie on the flat meshes' planes. A voxel counts as wrong when its sign
//! differs from the reference and `|w − ½| > 1e-9`.

use glam::DVec3;
use proptest::prelude::*;
use volga_core::NoProgress;
use volga_mesh::{unclean, TriMesh};
use volga_voxelize::check::{check_signs, grid_for};
use volga_voxelize::{MeshVoxelizer, SurfaceMode};

/// A mesh vendored in tests/data (see its README for provenance and licences).
fn shared(name: &str) -> TriMesh {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data")
        .join(name);
    volga_mesh::load_obj(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn assert_no_wrong_sign(name: &str, mesh: &TriMesh, n: u32, shift: f64, random: usize) {
    let grid = grid_for(mesh, n, 4.0, DVec3::splat(shift));
    for c in check_signs(mesh, &grid, 3.0, random, n as u64) {
        assert!(c.checked > 0, "{name}: nothing checked");
        assert_eq!(
            c.wrong, 0,
            "{name}, N = {n}, shift {shift}, {}: {} of {} wrong (worst |w − ½| {:.3e}); {:?}",
            c.mode, c.wrong, c.checked, c.worst, c.stats
        );
    }
}

#[test]
fn unclean_corpus_signs_equal_the_winding_number() {
    for (name, mesh) in unclean::corpus() {
        for shift in [0.0, 0.5] {
            assert_no_wrong_sign(name, &mesh, 20, shift, 2000);
        }
    }
}

#[test]
fn teapot_signs_equal_the_winding_number() {
    let teapot = shared("teapot.obj");
    assert_no_wrong_sign("teapot", &teapot, 32, 0.0, 4000);
}

#[test]
fn bunny_signs_equal_the_winding_number() {
    let bunny = shared("stanford-bunny.obj");
    assert_no_wrong_sign("bunny", &bunny, 20, 0.5, 2000);
}

#[test]
fn hard_meshes_say_so_in_their_stats() {
    // A closed clean sphere: every band voxel by its nearest triangle.
    let sphere = unclean::uv_sphere(DVec3::ZERO, 1.0, 12, 16);
    let grid = grid_for(&sphere, 24, 4.0, DVec3::ZERO);
    let (_, s) = MeshVoxelizer::new(&sphere).voxelize_with_stats(&grid, SurfaceMode::Solid, &NoProgress);
    assert_eq!(
        (s.unclean_triangles, s.boundary_cycle_edges, s.exact_band_voxels),
        (0, 0, 0)
    );
    assert!(s.fast_voxels > 1000);
    // Two overlapping spheres: the triangles along the intersection are unclean.
    let corpus = unclean::corpus();
    let union = &corpus
        .iter()
        .find(|(n, _)| *n == "self-intersecting union of two spheres")
        .unwrap()
        .1;
    let (_, s) = MeshVoxelizer::new(union).voxelize_with_stats(
        &grid_for(union, 24, 4.0, DVec3::ZERO),
        SurfaceMode::Solid,
        &NoProgress,
    );
    // Their band voxels leave the fast path: `I` carried from a trusted triangle near
    // them (counted with the caps' voxels, here `w = I`), or the whole mesh's query.
    assert!(
        s.unclean_triangles > 0 && s.cap_voxels + s.exact_band_voxels > 0,
        "{s:?}"
    );
    // A single triangle: a boundary cycle of three edges.
    let tri = &corpus.iter().find(|(n, _)| *n == "single triangle").unwrap().1;
    assert_eq!(MeshVoxelizer::new(tri).sign_stats().boundary_cycle_edges, 3);
}

#[test]
fn signs_are_identical_for_any_thread_count() {
    let corpus = unclean::corpus();
    for name in [
        "open scan with two holes",
        "sheet pierced by a sphere",
        "sphere with a flipped hemisphere",
    ] {
        let mesh = &corpus.iter().find(|(n, _)| *n == name).unwrap().1;
        let grid = grid_for(mesh, 24, 4.0, DVec3::ZERO);
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| MeshVoxelizer::new(mesh).voxelize_with_stats(&grid, SurfaceMode::Solid, &NoProgress))
        };
        let (one, one_stats) = run(1);
        let (two, two_stats) = run(2);
        assert_eq!(one_stats, two_stats, "{name}");
        for ijk in grid.index_box().iter() {
            assert_eq!(
                one.density.get(ijk).to_bits(),
                two.density.get(ijk).to_bits(),
                "{name} at {ijk}"
            );
        }
    }
}

fn soup() -> impl Strategy<Value = TriMesh> {
    let p = (-2.0f64..2.0, -2.0f64..2.0, -2.0f64..2.0).prop_map(|(x, y, z)| DVec3::new(x, y, z));
    (prop::collection::vec((p.clone(), p.clone(), p), 1..5), any::<bool>()).prop_map(|(triangles, with_sphere)| {
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        for (a, b, c) in triangles {
            let i = positions.len() as u32;
            positions.extend([a, b, c]);
            indices.push([i, i + 1, i + 2]);
        }
        let soup = TriMesh {
            positions,
            triangles: indices,
        };
        if with_sphere {
            unclean::concat(&soup, &unclean::uv_sphere(DVec3::new(0.3, -0.2, 0.1), 1.1, 6, 8))
        } else {
            soup
        }
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    /// Random soups (open triangles, alone or crossing a closed sphere), on random grid
    /// origins and far from the origin.
    #[test]
    fn random_soups_signs_equal_the_winding_number(
        mesh in soup(),
        shift in (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0),
        far in any::<bool>(),
    ) {
        let mesh = if far { mesh.translated(DVec3::splat(1e6)) } else { mesh };
        let grid = grid_for(&mesh, 12, 4.0, DVec3::new(shift.0, shift.1, shift.2));
        for c in check_signs(&mesh, &grid, 3.0, 500, 7) {
            prop_assert_eq!(c.wrong, 0, "{}: {} of {} wrong, worst {:.3e}", c.mode, c.wrong, c.checked, c.worst);
        }
    }
}
