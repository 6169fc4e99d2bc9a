//! Every extraction method on the inputs users bring: voxelizations of the unclean mesh
//! corpus (self-intersecting, overlapping, flipped, open, flat), solids touching the grid's
//! border, sheets one voxel thick, volumes 10⁶ from the origin, narrow-band distances and
//! ADFs (whose leaves of different sizes make the field jump). Each mesh is checked closed
//! and manifold from its triangles alone (edge–face incidence, one direction per side, every
//! vertex's link one cycle).

use glam::{DVec3, IVec3, UVec3};
use volga::core::{Aabb, Field, Filter, Grid, Sampled, SparseVolume, Transform};
use volga::mesh::{unclean, ExtractMethod, Extraction, TriMesh};
use volga::voxelize::{MeshJob, MeshJobMode};

/// volga-mesh's independent manifold check (`crates/volga-mesh/tests/common`), shared.
#[path = "../crates/volga-mesh/tests/common/mod.rs"]
#[allow(dead_code)]
mod mesh_common;

/// Not empty, and closed and manifold by [`mesh_common::check_closed_manifold`].
fn check_closed_manifold(mesh: &TriMesh, what: &str) {
    assert!(!mesh.triangles.is_empty(), "{what}: no triangles");
    mesh_common::check_closed_manifold(mesh, what);
}

/// Every method on a voxel volume: iso ½ of a density (0 of a distance) on the voxel-centre
/// lattice grown by one voxel, where the volume reads its background.
fn each_method_on(volume: &SparseVolume, iso: f64, what: &str) {
    let field = Sampled::new(volume, Filter::Trilinear);
    let h = volume.grid.transform.min_spacing();
    let b = volume.grid.center_bounds();
    let region = Aabb::new(b.min - h, b.max + h);
    let mut empty = None;
    for method in ExtractMethod::ALL {
        for adaptivity in [0.0, 0.3] {
            let job = Extraction::new(region, h, iso)
                .with_method(method)
                .with_adaptivity(adaptivity);
            let s = volga::mesh::extract_surface_with(&field, &job).unwrap();
            let what = format!("{what}, {} a={adaptivity}", method.name());
            // A volume with nothing inside (a flat sheet's solid) is empty for every method.
            let is_empty = *empty.get_or_insert(s.mesh.triangles.is_empty());
            if is_empty {
                assert!(
                    s.mesh.triangles.is_empty(),
                    "{what}: triangles where tetrahedra found none"
                );
            } else {
                check_closed_manifold(&s.mesh, &what);
            }
            // Normals are the field's gradient, outward and unit, however they were
            // found (from the block's voxels or by asking the field).
            let mut g = vec![DVec3::ZERO; s.mesh.positions.len()];
            field.gradients_at(&s.mesh.positions, &mut g);
            for (n, g) in s.normals.iter().zip(&g) {
                let expected = field.kind().outward(*g).normalize_or_zero();
                assert!(
                    (*n - expected).length() <= 1e-9,
                    "{what}: normal {n} against the gradient's {expected}"
                );
            }
        }
    }
}

fn voxelize(mesh: &TriMesh, mode: MeshJobMode, resolution: u32) -> SparseVolume {
    let job = MeshJob { resolution, mode };
    let grid = job.layout(&mesh.bounds()).unwrap();
    job.run(mesh, &grid, &volga::core::NoProgress).volume
}

#[test]
fn the_unclean_corpus_meshes_closed_and_manifold_by_every_method() {
    for (name, mesh) in unclean::corpus() {
        let solid = voxelize(
            &mesh,
            MeshJobMode::AntiAliased {
                thickness_voxels: 1.0,
                solid: true,
            },
            28,
        );
        each_method_on(&solid, 0.5, &format!("{name} (anti-aliased solid)"));
    }
}

#[test]
fn narrow_band_distances_and_far_offsets_mesh_closed() {
    let sphere = unclean::uv_sphere(DVec3::new(1e6, -1e6, 1e6), 1.0, 16, 24);
    let band = voxelize(
        &sphere,
        MeshJobMode::Distance {
            half_width_voxels: 3.0,
            signed: true,
        },
        32,
    );
    each_method_on(&band, 0.0, "sphere at 1e6, narrow band");
}

/// A density volume of `dims` voxels (spacing 0.5, origin `origin`) set to 1 where `inside`.
fn volume_where(dims: u32, origin: DVec3, inside: impl Fn(IVec3) -> bool) -> SparseVolume {
    let transform = Transform::new(origin, DVec3::splat(0.5)).unwrap();
    let grid = Grid::new(transform, UVec3::splat(dims)).unwrap();
    let mut v = SparseVolume::new(grid, 0.0, false);
    for z in 0..dims as i32 {
        for y in 0..dims as i32 {
            for x in 0..dims as i32 {
                let ijk = IVec3::new(x, y, z);
                if inside(ijk) {
                    v.density.set(ijk, 1.0);
                }
            }
        }
    }
    v
}

#[test]
fn solids_touching_the_border_and_one_voxel_sheets_close() {
    // A block filling a corner of the grid up to its faces.
    let corner = volume_where(12, DVec3::ZERO, |p| p.x < 7 && p.y < 9 && p.z >= 3);
    each_method_on(&corner, 0.5, "block touching the border");
    // A sheet one voxel thick, tilted across the grid, and one voxel-thin rods.
    let sheet = volume_where(16, DVec3::splat(-4.0), |p| p.x + p.y / 3 == 7 || (p.z == 2 && p.y == 5));
    each_method_on(&sheet, 0.5, "one-voxel sheet and rod");
    // Diagonal neighbours only (every ambiguous face and body case at once).
    let checker = volume_where(10, DVec3::new(1e6, 1e6, -1e6), |p| (p.x + p.y + p.z) % 2 == 0);
    each_method_on(&checker, 0.5, "3-D checkerboard at 1e6");
}

#[test]
fn adfs_with_jumping_leaves_mesh_closed() {
    let corpus = unclean::corpus();
    for (name, mesh) in corpus.iter().take(3) {
        let source = volga::adf::MeshSource::new(mesh).unwrap();
        let bounds = mesh.bounds();
        let adf = volga::adf::Adf::build(&source, volga::adf::AdfOptions::relative(1e-2, &bounds)).unwrap();
        let cell = bounds.size().max_element() / 30.0;
        let region = Aabb::new(bounds.min - 2.0 * cell, bounds.max + 2.0 * cell);
        for method in ExtractMethod::ALL {
            let job = Extraction::new(region, cell, 0.0).with_method(method);
            let s = adf.to_mesh_with(&job, u64::MAX).unwrap();
            check_closed_manifold(&s.mesh, &format!("ADF of {name}, {}", method.name()));
            assert_eq!(adf.kind(), volga::core::FieldKind::SignedDistance);
        }
    }
}

/// An ADF meshed on its own leaves (the dual grid: no lattice at the finest level) is closed
/// and manifold where leaves of different sizes meet, over the whole unclean corpus (open,
/// self-intersecting, overlapping meshes: jump leaves), and the same for 1 and 2 threads.
#[test]
fn adfs_meshed_on_their_own_leaves_are_closed_and_manifold() {
    for (name, mesh) in unclean::corpus() {
        let source = volga::adf::MeshSource::new(&mesh).unwrap();
        let bounds = mesh.bounds();
        let adf = volga::adf::Adf::build(&source, volga::adf::AdfOptions::relative(1e-2, &bounds)).unwrap();
        for method in [ExtractMethod::Cubes, ExtractMethod::Tetrahedra] {
            let s = adf.to_mesh_on_leaves(method, 0.0, u64::MAX).unwrap();
            if s.mesh.triangles.is_empty() {
                // No inside at all (a flat sheet): every leaf centre is outside.
                let (leaves, _) = adf.dual_grid();
                assert!(
                    leaves.iter().all(|l| l.value > 0.0),
                    "{name}: the leaves missed a surface"
                );
                continue;
            }
            check_closed_manifold(&s.mesh, &format!("ADF of {name} on its leaves, {}", method.name()));
            if method == ExtractMethod::Tetrahedra {
                continue;
            }
            let one = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap()
                .install(|| adf.to_mesh_on_leaves(method, 0.0, u64::MAX).unwrap());
            assert_eq!(one, s, "{name}: thread count changed the mesh");
        }
    }
}
