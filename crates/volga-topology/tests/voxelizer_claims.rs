//! volga's voxelizers checked by the validator: every separability (and minimality,
//! and cover) claim they make, on random triangles, closed meshes and quadrics. From
//! now on this is how the voxelizers' claims are checked.
//!
//! Claims (crate docs of volga-voxelize):
//! * `voxelize_triangles` with separability N: no white N-adjacent pair has a segment
//!   meeting a triangle (no N-tunnel); with N = 26 the black cells cover the triangles
//!   (K₂₆ is the voxel's own cell); a plane gives an N-minimal slab (in a finite grid
//!   only voxels of the border layer can be N-simple: their other side lies outside).
//! * `voxelize_shapes` with `SurfaceMode::Binary(N)`: no white N-adjacent pair
//!   straddles the surface (signed distance ≤ 0 at one centre, > 0 at the other).

use glam::{DMat3, DQuat, DVec3, IVec3, UVec3};
use proptest::prelude::*;
use volga_core::{Grid, NoProgress, Transform};
use volga_mesh::TriMesh;
use volga_topology::{analyze, check_mesh, tunnels, Connectivity, SurfaceMesh, VoxelSet};
use volga_voxelize::shapes::{AxisBox, Cylinder, Ellipsoid, Quadric, Sphere};
use volga_voxelize::{voxelize_shapes, voxelize_triangles, Separability, Shape, SignedDistance, SurfaceMode};

const ALL: [(Separability, Connectivity); 3] = [
    (Separability::Six, Connectivity::Six),
    (Separability::Eighteen, Connectivity::Eighteen),
    (Separability::TwentySix, Connectivity::TwentySix),
];

/// A 14³ grid placed off the world origin with spacing 0.5, all dyadic, so that
/// lattice points map to index space exactly (the voxelizers decide ties exactly only
/// then; see the ignored tests at the end for what rounding does).
fn grid() -> Grid {
    let t = Transform::new(DVec3::new(0.375, -1.25, 5.0), DVec3::splat(0.5)).unwrap();
    Grid::new(t, UVec3::splat(14)).unwrap()
}

fn black_set(volume: &volga_core::SparseVolume) -> VoxelSet {
    VoxelSet::from_sparse(volume, 0.5).unwrap()
}

/// A triangle inside the grid's cells (index coordinates in `[−½, 13.5]`), in world
/// space: either all three corners on the quarter-voxel lattice, where ties occur and
/// are decided exactly, or all three arbitrary.
fn triangle() -> impl Strategy<Value = [DVec3; 3]> {
    let lattice = (-2i32..=54).prop_map(|q| q as f64 * 0.25);
    let any = -0.5f64..13.5;
    let corner = |c: BoxedStrategy<f64>| (c.clone(), c.clone(), c).prop_map(DVec3::from);
    prop_oneof![
        proptest::array::uniform3(corner(lattice.boxed())),
        proptest::array::uniform3(corner(any.boxed())),
    ]
    .prop_map(|t| t.map(|p| grid().transform.index_to_world(p)))
}

fn triangles() -> impl Strategy<Value = Vec<[DVec3; 3]>> {
    proptest::collection::vec(triangle(), 1..4)
}

/// A world point inside the grid.
fn point() -> impl Strategy<Value = DVec3> {
    (0.0f64..13.0, 0.0f64..13.0, 0.0f64..13.0).prop_map(|p| grid().transform.index_to_world(DVec3::from(p)))
}

fn rotation() -> impl Strategy<Value = DQuat> {
    (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, 0.0f64..6.3).prop_map(|(x, y, z, angle)| {
        let axis = DVec3::new(x, y, z);
        if axis.length() < 1e-3 {
            DQuat::IDENTITY
        } else {
            DQuat::from_axis_angle(axis.normalize(), angle)
        }
    })
}

/// Pairs of white N-neighbours that straddle a surface given by its signed distance.
fn straddles(set: &VoxelSet, n: Connectivity, grid: &Grid, shape: &(impl SignedDistance + Sync)) -> usize {
    let inside = |v: IVec3| shape.signed_distance(grid.transform.voxel_center(v)) <= 0.0;
    tunnels(set, n, grid.index_box().iter(), |a, b| inside(a) != inside(b)).len()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn triangles_have_no_tunnels_and_26_covers(tris in triangles()) {
        let g = grid();
        let surface = SurfaceMesh::from_world(tris.iter().copied(), &g.transform);
        for (sep, n) in ALL {
            let set = black_set(&voxelize_triangles(&g, &tris, sep, &NoProgress));
            let m = check_mesh(&set, n, &surface, 4);
            prop_assert!(m.separating, "{}: {} tunnels at {:?}", n, m.tunnel_count, m.tunnels);
            if sep == Separability::TwentySix {
                prop_assert!(m.covers, "uncovered: {:?}", m.uncovered);
            }
        }
    }

    #[test]
    fn closed_boxes_separate(
        centre in (6.0f64..7.0, 6.0f64..7.0, 6.0f64..7.0),
        half in (2.6f64..3.5, 2.6f64..3.5, 2.6f64..3.5),
        rot in rotation(),
    ) {
        // A rotated box mesh (index space) inside the grid, voxelized in world space.
        let g = grid();
        let cube = TriMesh::from_aabb(&volga_core::Aabb::new(-DVec3::from(half), DVec3::from(half)));
        let tris: Vec<[DVec3; 3]> = (0..cube.triangle_count())
            .map(|i| cube.triangle(i).map(|p| g.transform.index_to_world(rot * p + DVec3::from(centre))))
            .collect();
        let surface = SurfaceMesh::from_world(tris.iter().copied(), &g.transform);
        for (sep, n) in ALL {
            let set = black_set(&voxelize_triangles(&g, &tris, sep, &NoProgress));
            let m = check_mesh(&set, n, &surface, 4);
            prop_assert!(m.separating, "{}: {} tunnels at {:?}", n, m.tunnel_count, m.tunnels);
            let report = analyze(&set, n);
            prop_assert!(report.white_component_count >= 2, "{}: the inside is not cut off", n);
        }
    }

    #[test]
    fn planes_are_minimal_away_from_the_border(
        p in point(),
        normal in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
    ) {
        let normal = DVec3::from(normal);
        prop_assume!(normal.length() > 0.1);
        // One triangle far larger than the grid: a plane through it.
        let u = normal.any_orthonormal_vector();
        let w = normal.cross(u).normalize();
        let big = [p + u * 100.0, p - u * 50.0 + w * 90.0, p - u * 50.0 - w * 90.0];
        let g = grid();
        for (sep, n) in ALL {
            let set = black_set(&voxelize_triangles(&g, &[big], sep, &NoProgress));
            let surface = SurfaceMesh::from_world([big], &g.transform);
            let m = check_mesh(&set, n, &surface, 4);
            prop_assert!(m.separating);
            let report = analyze(&set, n);
            let last = g.dims().as_ivec3() - 1;
            let on_border = |v: IVec3| v.cmpeq(IVec3::ZERO).any() || v.cmpeq(last).any();
            let white = volga_topology::white_components(&set, n);
            let inner_simple: Vec<IVec3> = volga_topology::simple_voxels_with(&set, &white)
                .into_iter()
                .filter(|&v| !on_border(v))
                .collect();
            prop_assert!(
                report.white_component_count < 2 || inner_simple.is_empty(),
                "{}: simple voxels inside the grid: {:?}", n, inner_simple
            );
        }
    }

    #[test]
    fn binary_quadrics_do_not_straddle(
        centre in (3.0f64..4.0, 1.5f64..2.5, 7.7f64..8.7),
        radii in (0.8f64..2.5, 0.8f64..2.5, 0.8f64..2.5),
        rot in rotation(),
        kind in 0usize..4,
    ) {
        let g = grid();
        let c = DVec3::from(centre);
        let r = DVec3::from(radii);
        let shape = match kind {
            0 => Shape::Sphere(Sphere::new(c, r.x).unwrap()),
            1 => Shape::Ellipsoid(Ellipsoid::new(c, r, rot).unwrap()),
            2 => Shape::Cylinder(Cylinder::new(c, rot * DVec3::Z, r.x, Some(r.y)).unwrap()),
            _ => {
                // A hyperboloid of one sheet x² + y² − z² = ρ², rotated, clipped by a box.
                let m = DMat3::from_quat(rot);
                let a = m * DMat3::from_diagonal(DVec3::new(1.0, 1.0, -1.0)) * m.transpose();
                let b = -2.0 * (a * c);
                let k = c.dot(a * c) - r.x * r.x;
                let clip = AxisBox::new(c - 2.5, c + 2.5).unwrap();
                Shape::Quadric(Quadric::new(a, b, k, clip).unwrap())
            }
        };
        for (sep, n) in ALL {
            let set = black_set(&voxelize_shapes(&g, &[shape], SurfaceMode::Binary(sep), &NoProgress));
            prop_assert_eq!(straddles(&set, n, &g, &shape), 0, "{} kind {}", n, kind);
        }
    }
}

/// Found by the property test above on a grid whose origin is not dyadic
/// (0.3, −1.2, 5.0): a vertex exactly at the centre of the face between voxels
/// (1, 7, 5) and (1, 7, 6) (index (1, 7, 5.5)), the other corners arbitrary. The
/// 6-separating slab test `−h ≤ n·(v − a) < h` meets the tie `n·(v − a) = −h` in
/// rounded arithmetic and drops both voxels, leaving a 6-tunnel through the vertex.
/// Regression: fixed by the voxelizer's rounding guard (closed intervals widened by a
/// relative ε, the half-open window shifted by −ε).
#[test]
fn known_tunnel_at_a_vertex_on_a_face_centre() {
    let t = Transform::new(DVec3::new(0.3, -1.2, 5.0), DVec3::splat(0.5)).unwrap();
    let g = Grid::new(t, UVec3::splat(14)).unwrap();
    let tri = [
        DVec3::new(3.2768398290806022, 4.425, 8.75),
        DVec3::new(0.8, 2.3, 7.75),
        DVec3::new(4.675, 1.175, 5.625),
    ];
    let set = black_set(&voxelize_triangles(&g, &[tri], Separability::Six, &NoProgress));
    let m = check_mesh(
        &set,
        Connectivity::Six,
        &SurfaceMesh::from_world([tri], &g.transform),
        4,
    );
    assert!(m.separating, "{:?}", m.tunnels);
}

/// Also from a non-dyadic origin: a lattice triangle whose corner maps to index
/// x = 3.4999999999999996 pokes ~1e-17 into the open cell of voxel (3, 8, 6), which
/// the 26-separating voxelization leaves white: not a cover, by a rounding error.
#[test]
#[ignore = "a 4e-16 sliver past a face plane: covering it would take the upper layer at every face tie, \
            against the one-layer rule for planes on voxel faces (exact in exact arithmetic)"]
fn known_uncovered_sliver_after_rounding() {
    let t = Transform::new(DVec3::new(0.3, -1.2, 5.0), DVec3::splat(0.5)).unwrap();
    let g = Grid::new(t, UVec3::splat(14)).unwrap();
    let tri = [
        DVec3::new(3.3, 3.8, 7.75),
        DVec3::new(2.05, 2.55, 7.75),
        DVec3::new(0.675, -1.2, 7.875),
    ];
    let set = black_set(&voxelize_triangles(&g, &[tri], Separability::TwentySix, &NoProgress));
    let m = check_mesh(
        &set,
        Connectivity::TwentySix,
        &SurfaceMesh::from_world([tri], &g.transform),
        4,
    );
    assert!(m.covers, "{:?}", m.uncovered);
}
