//! Every voxelizer says what its scalar channel holds (`SparseVolume::density_kind`),
//! and the values agree with the claim: binary results are exactly 0/1, densities lie in
//! [0, 1], signed distances reach below zero inside and are clamped to the background
//! band. `MeshVoxelizer::voxelize` serves every `SurfaceMode`, binary ones included.

use glam::{DVec3, UVec3};
use volga_core::{Aabb, ChannelKind, Grid, NoProgress, SparseVolume, Transform};
use volga_mesh::TriMesh;
use volga_voxelize::shapes::Sphere;
use volga_voxelize::{
    voxelize_mesh_surface, voxelize_segments, voxelize_shapes, voxelize_solids, voxelize_triangles, LineConnectivity,
    MeshVoxelizer, Separability, Shape, Solid, SurfaceMode,
};

fn grid() -> Grid {
    Grid::new(
        Transform::new(DVec3::ZERO, DVec3::splat(0.5)).unwrap(),
        UVec3::splat(24),
    )
    .unwrap()
}

fn cube() -> TriMesh {
    TriMesh::from_aabb(&Aabb::new(DVec3::splat(2.1), DVec3::splat(8.7)))
}

fn sphere() -> Shape {
    Shape::Sphere(Sphere::new(DVec3::splat(6.0), 3.7).unwrap())
}

/// Every stored value of the scalar channel (the grid's voxels).
fn values(v: &SparseVolume) -> Vec<f32> {
    v.grid.index_box().iter().map(|ijk| v.density.get(ijk)).collect()
}

/// The values are what `kind` says.
fn check(v: &SparseVolume, kind: ChannelKind, what: &str) {
    assert_eq!(v.density_kind, kind, "{what}");
    assert_eq!(v.channels()[0], ("density", kind), "{what}");
    let vals = values(v);
    assert!(
        vals.iter().any(|&x| x != v.density.background()),
        "{what}: empty result"
    );
    match kind {
        ChannelKind::Binary => assert!(vals.iter().all(|&x| x == 0.0 || x == 1.0), "{what}"),
        ChannelKind::Density => {
            assert!(vals.iter().all(|&x| (0.0..=1.0).contains(&x)), "{what}");
            assert!(vals.iter().any(|&x| x > 0.0 && x < 1.0), "{what}: not anti-aliased");
        }
        ChannelKind::SignedDistance => {
            let band = v.density.background();
            assert!(band > 0.0, "{what}");
            assert!(vals.iter().all(|&x| x.abs() <= band), "{what}");
        }
        ChannelKind::Colour => panic!("{what}: a scalar channel never holds colour"),
    }
}

fn modes() -> Vec<(SurfaceMode, ChannelKind)> {
    let mut m = vec![
        (SurfaceMode::Solid, ChannelKind::Density),
        (SurfaceMode::Shell { thickness: 0.5 }, ChannelKind::Density),
        (
            SurfaceMode::Distance {
                half_width_voxels: 3.0,
                signed: true,
            },
            ChannelKind::SignedDistance,
        ),
        (
            SurfaceMode::Distance {
                half_width_voxels: 3.0,
                signed: false,
            },
            ChannelKind::SignedDistance,
        ),
        (SurfaceMode::Inside, ChannelKind::Binary),
    ];
    m.extend(Separability::ALL.map(|s| (SurfaceMode::Binary(s), ChannelKind::Binary)));
    m
}

#[test]
fn shapes_in_every_mode() {
    for (mode, kind) in modes() {
        assert_eq!(mode.channel_kind(), kind);
        let v = voxelize_shapes(&grid(), &[sphere()], mode, &NoProgress);
        check(&v, kind, &format!("voxelize_shapes {mode:?}"));
    }
}

#[test]
fn meshes_in_every_mode_without_panic() {
    let mesh = cube();
    let mv = MeshVoxelizer::new(&mesh);
    for (mode, kind) in modes() {
        let v = mv.voxelize(&grid(), mode, &NoProgress);
        check(&v, kind, &format!("MeshVoxelizer {mode:?}"));
        if let SurfaceMode::Distance { signed: true, .. } = mode {
            assert!(values(&v).iter().any(|&d| d < 0.0), "signed distance has an inside");
        }
        if let SurfaceMode::Binary(sep) = mode {
            // The binary surface of the mesh, voxel for voxel.
            let direct = voxelize_mesh_surface(&grid(), &mesh, sep, &NoProgress);
            assert_eq!(values(&v), values(&direct), "{sep}");
            assert_eq!(v.density.sorted_bricks(), direct.density.sorted_bricks());
        }
    }
}

#[test]
fn binary_triangles_lines_and_solids() {
    let mesh = cube();
    for sep in Separability::ALL {
        check(
            &voxelize_mesh_surface(&grid(), &mesh, sep, &NoProgress),
            ChannelKind::Binary,
            "voxelize_mesh_surface",
        );
        let tris: Vec<[DVec3; 3]> = (0..mesh.triangles.len()).map(|i| mesh.triangle(i)).collect();
        check(
            &voxelize_triangles(&grid(), &tris, sep, &NoProgress),
            ChannelKind::Binary,
            "voxelize_triangles",
        );
    }
    for c in [LineConnectivity::SIX, LineConnectivity::TWENTY_SIX] {
        let segs = [[DVec3::splat(1.0), DVec3::new(9.0, 4.0, 2.5)]];
        check(
            &voxelize_segments(&grid(), &segs, c, &NoProgress),
            ChannelKind::Binary,
            "lines",
        );
    }
    let solids = [Solid::new(sphere(), [1.0, 0.5, 0.0])];
    let v = voxelize_solids(&grid(), &solids, true, &NoProgress);
    check(&v, ChannelKind::Density, "voxelize_solids");
    assert_eq!(v.channels()[1], ("colour", ChannelKind::Colour));
}

#[test]
fn lines_refuse_eighteen_connectivity() {
    use volga_core::Adjacency;
    assert_eq!(LineConnectivity::new(Adjacency::Six), Ok(LineConnectivity::SIX));
    assert_eq!(
        LineConnectivity::try_from(Adjacency::TwentySix),
        Ok(LineConnectivity::TWENTY_SIX)
    );
    let err = LineConnectivity::new(Adjacency::Eighteen).unwrap_err();
    assert_eq!(err.to_string(), "lines are 6- or 26-connected, not 18-connected");
}
