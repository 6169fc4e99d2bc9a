//! Hand-made voxel sets whose topology is known by construction.

use glam::{IVec3, UVec3};
use volga_topology::brute::grid_voxels;
use volga_topology::{
    analyze, betti_numbers, black_components, euler_characteristic, is_minimal, is_simple, is_simple_local,
    leaks_if_removed, simple_voxels, tunnels, white_components, Betti, Connectivity, Region, VoxelSet,
};

const SIX: Connectivity = Connectivity::Six;
const EIGHTEEN: Connectivity = Connectivity::Eighteen;
const TWENTY_SIX: Connectivity = Connectivity::TwentySix;

fn set_where(dims: UVec3, black: impl Fn(IVec3) -> bool) -> VoxelSet {
    VoxelSet::from_voxels(dims, grid_voxels(dims).filter(|&v| black(v))).unwrap()
}

fn separating(set: &VoxelSet, n: Connectivity) -> bool {
    white_components(set, n).len() >= 2
}

#[test]
fn diagonal_plane_is_6_separating_but_not_18_or_26() {
    // x + y = 7: consecutive voxels share an edge, so the plane is 18-connected (not
    // 6). A 6-step changes x + y by 1, so white 6-paths cannot get from x + y ≤ 6 to
    // x + y ≥ 8; but (3, 3) and (4, 4) are 18-adjacent across the plane.
    let plane = set_where(UVec3::new(8, 8, 4), |v| v.x + v.y == 7);
    let report = analyze(&plane, SIX);
    assert!(report.separating);
    assert_eq!(report.white_component_count, 2);
    assert!(report.minimal, "every voxel sees both sides through faces");
    assert!(!separating(&plane, EIGHTEEN));
    assert!(!separating(&plane, TWENTY_SIX));
    assert_eq!(black_components(&plane, EIGHTEEN).len(), 1);
    assert_eq!(
        black_components(&plane, SIX).len(),
        8,
        "one 6-connected column per (x, y)"
    );
}

#[test]
fn staircase_plane_is_26_separating() {
    // x + y ∈ {7, 8}: a 26-step changes x + y by at most 2, too little to jump from
    // ≤ 6 to ≥ 9. The staircase itself is 6-connected.
    let stairs = set_where(UVec3::new(8, 8, 4), |v| v.x + v.y == 7 || v.x + v.y == 8);
    let report = analyze(&stairs, TWENTY_SIX);
    assert!(report.separating);
    assert_eq!(report.white_component_count, 2);
    assert_eq!(black_components(&stairs, SIX).len(), 1);
    // Only the two end columns are simple: (7, 0) and (0, 7) have no 26-neighbour with
    // x + y ≥ 9 inside the grid, so removing them merges nothing.
    let expected: Vec<IVec3> = (0..4)
        .flat_map(|z| [IVec3::new(7, 0, z), IVec3::new(0, 7, z)])
        .collect();
    assert_eq!(simple_voxels(&stairs, TWENTY_SIX), expected);
    assert_eq!(report.simple_voxel_count, Some(8));
    assert!(!report.minimal);
}

/// Voxels of the ball `‖v − c‖ ≤ r` that are N-adjacent to a voxel outside it: a
/// closed shell that is N-separating (an interior voxel has all its N-neighbours in
/// the ball, so no white N-step leaves the ball except through the shell).
fn sphere_shell(dims: UVec3, centre: IVec3, radius: f64, n: Connectivity) -> VoxelSet {
    let in_ball = |v: IVec3| (v - centre).as_dvec3().length() <= radius;
    set_where(dims, |v| in_ball(v) && n.offsets().iter().any(|&d| !in_ball(v + d)))
}

#[test]
fn sphere_shell_with_one_voxel_removed_leaks_at_that_voxel() {
    let (dims, centre, radius) = (UVec3::splat(15), IVec3::splat(7), 5.3);
    let in_ball = |v: IVec3| (v - centre).as_dvec3().length() <= radius;
    let crosses = |a: IVec3, b: IVec3| in_ball(a) != in_ball(b);
    let band: Vec<IVec3> = grid_voxels(dims)
        .filter(|v| ((*v - centre).as_dvec3().length() - radius).abs() <= 2.0)
        .collect();
    for n in Connectivity::ALL {
        let shell = sphere_shell(dims, centre, radius, n);
        let report = analyze(&shell, n);
        assert!(report.separating, "{n}");
        assert_eq!(report.white_component_count, 2, "{n}");
        let regions: Vec<Region> = report.white_components.iter().map(|c| c.region).collect();
        assert_eq!(regions, vec![Region::Outside, Region::Inside], "{n}");
        let inside = &report.white_components[1].component;
        assert!(inside.bbox_min.cmpgt(centre - IVec3::splat(6)).all() && inside.bbox_max.cmplt(centre + 6).all());
        assert!(tunnels(&shell, n, band.iter().copied(), crosses).is_empty(), "{n}");

        // The first voxel whose removal merges inside and outside.
        let white = white_components(&shell, n);
        let spot = shell
            .iter()
            .find(|&v| !is_simple(&shell, &white, v))
            .expect("a thin spot");
        let leaks = leaks_if_removed(&shell, &white, &[spot]);
        assert_eq!(leaks.len(), 1);
        assert_eq!(leaks[0].voxel, spot);
        let sides: Vec<Option<u32>> = leaks[0].white_voxels.iter().map(|&w| white.label_at(w)).collect();
        assert_eq!(sides, vec![Some(0), Some(1)], "one witness outside, one inside");

        let mut holed = shell.clone();
        holed.remove(spot);
        let report = analyze(&holed, n);
        assert!(!report.separating, "{n}");
        assert_eq!(report.simple_voxel_count, None);
        // Every N-tunnel through the sphere now passes through the removed voxel.
        let found = tunnels(&holed, n, band.iter().copied(), crosses);
        assert!(!found.is_empty(), "{n}");
        assert!(
            found.iter().all(|t| t.a == spot || t.b == spot),
            "{n}: {found:?} vs {spot}"
        );
    }
}

#[test]
fn doubled_layer_is_separating_but_not_minimal() {
    let dims = UVec3::new(6, 5, 8);
    let single = set_where(dims, |v| v.z == 3);
    let doubled = set_where(dims, |v| v.z == 3 || v.z == 4);
    for n in Connectivity::ALL {
        assert!(is_minimal(&single, n), "{n}");
        let report = analyze(&doubled, n);
        assert!(report.separating && !report.minimal, "{n}");
        // Each voxel of either layer sees white on one side only: all are simple.
        assert_eq!(report.simple_voxel_count, Some(60));
        assert_eq!(simple_voxels(&doubled, n), doubled.iter().collect::<Vec<_>>());
        assert_eq!(report.simple_voxels.len(), 32, "listed up to the default limit");
        assert_eq!(report.checks.last().unwrap().voxel, Some(IVec3::new(0, 0, 3)));
        // Removing the extra layer leaves a minimal one.
        let mut thinned = doubled.clone();
        for v in single.iter() {
            thinned.remove(v + IVec3::Z);
        }
        assert_eq!(thinned, single);
    }
}

#[test]
fn local_and_exact_simplicity_differ_on_a_fin() {
    // A wall x = 5 splits off the slab x = 6; a fin x = 2, y ≤ 3 stands in the larger
    // region with its free edge at y = 3 (white goes around it through y = 4).
    let fin = set_where(UVec3::new(7, 5, 5), |v| v.x == 5 || (v.x == 2 && v.y <= 3));
    let v = IVec3::new(2, 1, 2);
    for n in Connectivity::ALL {
        let white = white_components(&fin, n);
        assert_eq!(white.len(), 2, "{n}");
        // Both sides of the fin are one region: removing v merges nothing (exact),
        // but inside v's 3×3×3 the fin cuts them apart (local).
        assert!(is_simple(&fin, &white, v), "{n}");
        assert!(!is_simple_local(&fin, v, n), "{n}");
        // On the wall, where the two sides are different regions, they agree.
        let w = IVec3::new(5, 2, 2);
        assert!(!is_simple(&fin, &white, w) && !is_simple_local(&fin, w, n), "{n}");
    }
    // Doubled layer: the white neighbours lie on one side, connected locally.
    let doubled = set_where(UVec3::new(5, 5, 6), |v| v.z == 2 || v.z == 3);
    for n in Connectivity::ALL {
        assert!(is_simple_local(&doubled, IVec3::new(2, 2, 2), n));
    }
}

#[test]
fn euler_characteristic_of_known_solids() {
    let cube_minus_centre = set_where(UVec3::splat(3), |v| v != IVec3::ONE);
    let ring = set_where(UVec3::new(3, 3, 1), |v| v != IVec3::new(1, 1, 0));
    let corner_pair = VoxelSet::from_voxels(UVec3::splat(2), [IVec3::ZERO, IVec3::ONE]).unwrap();
    let single = VoxelSet::from_voxels(UVec3::splat(3), [IVec3::ONE]).unwrap();
    let betti = |b0, b1, b2, euler_characteristic| Betti {
        b0,
        b1,
        b2,
        euler_characteristic,
    };
    assert_eq!(betti_numbers(&single), betti(1, 0, 0, 1));
    assert_eq!(betti_numbers(&cube_minus_centre), betti(1, 0, 1, 2), "one cavity");
    assert_eq!(betti_numbers(&ring), betti(1, 1, 0, 0), "one handle");
    assert_eq!(
        betti_numbers(&corner_pair),
        betti(1, 0, 0, 1),
        "cubes meeting at a vertex"
    );
    // A 5×5×5 box shell with a 1×1 hole bored through two opposite faces: a hollow
    // torus (χ = 0) whose cavity opened into a handle.
    let shell = set_where(UVec3::splat(5), |v| {
        let on_shell = v.cmpeq(IVec3::ZERO).any() || v.cmpeq(IVec3::splat(4)).any();
        let bored = v.x == 2 && v.y == 2;
        on_shell && !bored
    });
    assert_eq!(euler_characteristic(&shell), 0);
    let report = analyze(&shell.padded(1).unwrap(), SIX);
    assert_eq!((report.cavities, report.handles), (0, 1));
}

#[test]
fn report_is_the_same_for_one_and_two_threads() {
    // A sphere shell plus pseudo-random specks: many components, simple voxels.
    let dims = UVec3::new(23, 19, 21);
    let shell = sphere_shell(dims, IVec3::new(11, 9, 10), 7.5, TWENTY_SIX);
    let mut voxels: Vec<IVec3> = shell.iter().collect();
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    voxels.extend(grid_voxels(dims).filter(|_| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        state >> 60 == 0
    }));
    let set = VoxelSet::from_voxels(dims, voxels).unwrap();
    for n in Connectivity::ALL {
        let pool = |threads| rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let one = pool(1).install(|| analyze(&set, n));
        let two = pool(2).install(|| analyze(&set, n));
        assert_eq!(one, two, "{n}");
        assert!(one.black_component_count > 1 && one.white_component_count > 1);
    }
}

#[test]
fn report_serializes_with_documented_names() {
    let set = set_where(UVec3::new(4, 4, 5), |v| v.z == 2);
    let json = serde_json::to_value(analyze(&set, TWENTY_SIX)).unwrap();
    assert_eq!(json["connectivity"], 26);
    assert_eq!(json["black_connectivity"], 6);
    assert_eq!(json["dims"], serde_json::json!([4, 4, 5]));
    assert_eq!(json["separating"], true);
    assert_eq!(json["white_components"][1]["region"], "outside");
    assert_eq!(json["white_components"][1]["first_voxel"], serde_json::json!([0, 0, 3]));
    assert_eq!(json["white_components"][1]["voxel_count"], 32);
    assert_eq!(json["checks"][2]["name"], "separating");
    assert_eq!(json["simple_voxel_count"], 0);
}
