//! The run-based algorithms against brute-force definitions on small random grids.

use glam::{IVec3, UVec3};
use proptest::prelude::*;
use volga_topology::brute::{bfs_components, brute_euler, brute_simple, grid_voxels, white_bfs};
use volga_topology::{
    betti_numbers, black_components, euler_characteristic, is_simple, is_simple_local, simple_voxels, white_components,
    Components, Connectivity, VoxelSet,
};

/// A random set: grid dims and a bit per voxel (density varies with `threshold`).
fn random_set(max_dim: u32) -> impl Strategy<Value = VoxelSet> {
    (1..=max_dim, 1..=max_dim, 1..=max_dim, 0u32..=100, any::<u64>()).prop_map(|(x, y, z, threshold, seed)| {
        let dims = UVec3::new(x, y, z);
        let mut state = seed | 1;
        let voxels: Vec<IVec3> = grid_voxels(dims)
            .filter(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state % 100) < threshold as u64
            })
            .collect();
        VoxelSet::from_voxels(dims, voxels).unwrap()
    })
}

fn assert_same_components(ours: &Components, brute: &[(IVec3, Vec<IVec3>, bool)]) -> Result<(), TestCaseError> {
    prop_assert_eq!(ours.len(), brute.len());
    for (label, (c, (first, voxels, border))) in ours.components().iter().zip(brute).enumerate() {
        prop_assert_eq!(c.label as usize, label);
        prop_assert_eq!(c.first_voxel, *first);
        prop_assert_eq!(c.voxel_count, voxels.len() as u64);
        prop_assert_eq!(c.touches_border, *border);
        let min = voxels.iter().fold(IVec3::MAX, |a, &v| a.min(v));
        let max = voxels.iter().fold(IVec3::MIN, |a, &v| a.max(v));
        prop_assert_eq!((c.bbox_min, c.bbox_max), (min, max));
        for &v in voxels {
            prop_assert_eq!(ours.label_at(v), Some(label as u32));
        }
    }
    Ok(())
}

proptest! {
    #[test]
    fn components_equal_bfs(set in random_set(7)) {
        for n in Connectivity::ALL {
            let black = bfs_components(set.dims(), |v| set.contains(v), n);
            assert_same_components(&black_components(&set, n), &black)?;
            assert_same_components(&white_components(&set, n), &white_bfs(&set, n))?;
        }
    }

    #[test]
    fn euler_and_betti_equal_brute_force(set in random_set(6)) {
        let chi = euler_characteristic(&set);
        prop_assert_eq!(chi, brute_euler(&set));
        let betti = betti_numbers(&set);
        let b0 = bfs_components(set.dims(), |v| set.contains(v), Connectivity::TwentySix).len() as i64;
        let b2 = white_bfs(&set, Connectivity::Six).iter().filter(|c| !c.2).count() as i64;
        prop_assert!(b0 + b2 - chi >= 0, "b1 < 0");
        prop_assert_eq!((betti.b0 as i64, betti.b1 as i64, betti.b2 as i64), (b0, b0 + b2 - chi, b2));
        // Padding adds white around the grid; the black solid is unchanged.
        prop_assert_eq!(euler_characteristic(&set.padded(1).unwrap()), chi);
    }

    #[test]
    fn simplicity_equals_its_definition_and_local_is_sound(set in random_set(5)) {
        for n in Connectivity::ALL {
            let white = white_components(&set, n);
            let simple = simple_voxels(&set, n);
            for v in set.iter() {
                let exact = is_simple(&set, &white, v);
                prop_assert_eq!(exact, brute_simple(&set, v, n), "{} at {}", n, v);
                prop_assert_eq!(exact, simple.contains(&v));
                if is_simple_local(&set, v, n) {
                    prop_assert!(exact, "locally simple but not simple: {} at {}", n, v);
                }
            }
        }
    }

    #[test]
    fn voxel_sets_store_what_they_are_given(
        dims in (1u32..9, 1u32..9, 1u32..9),
        raw in proptest::collection::vec((0i32..9, 0i32..9, 0i32..9), 0..60),
    ) {
        let dims = UVec3::new(dims.0, dims.1, dims.2);
        let voxels: Vec<IVec3> = raw.into_iter().map(IVec3::from).filter(|v| v.cmplt(dims.as_ivec3()).all()).collect();
        let set = VoxelSet::from_voxels(dims, voxels.iter().copied()).unwrap();
        let mut expected = voxels.clone();
        expected.sort_by_key(|v| (v.z, v.y, v.x));
        expected.dedup();
        prop_assert_eq!(set.iter().collect::<Vec<_>>(), expected.clone());
        prop_assert_eq!(set.len(), expected.len() as u64);
        for v in grid_voxels(dims) {
            prop_assert_eq!(set.contains(v), expected.contains(&v));
        }
        let padded = set.padded(2).unwrap();
        prop_assert_eq!(padded.iter().collect::<Vec<_>>(), expected.iter().map(|&v| v + 2).collect::<Vec<_>>());
    }
}
