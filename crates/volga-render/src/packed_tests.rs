//! The packed copy against the `Sampled` field it copies, and its lane fetches.

use glam::UVec3;

use super::*;
use volga_core::{DenseVolume, Field, Filter, GradientMethod, Sampled, SparseVolume, Transform};

/// The packed copy of `v` as the renderer makes it (a trilinear, central-difference
/// `Sampled` over it).
fn pack(v: &SparseVolume) -> Option<PackedVolume> {
    PackedVolume::of_field(&Sampled::new(v, Filter::Trilinear).with_gradient(GradientMethod::CentralDifference))
}

/// A deterministic uniform generator on `[0, 1)` (a 64-bit LCG's top 53 bits).
fn uniform(mut state: u64) -> impl FnMut() -> f64 {
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn volume(dims: UVec3, background: f32) -> SparseVolume {
    let grid = Grid::new(
        Transform::new(DVec3::new(-3.0, 1e3, 2.0), DVec3::new(0.5, 0.25, 0.75)).unwrap(),
        dims,
    )
    .unwrap();
    let mut dense = DenseVolume::new(grid, background, false).unwrap();
    for ijk in grid.index_box().iter() {
        let h = ijk.x.wrapping_mul(73_856_093) ^ ijk.y.wrapping_mul(19_349_663) ^ ijk.z.wrapping_mul(83_492_791);
        // Noise plus a uniform slab (z < 20) to exercise shared tiles.
        let v = if ijk.z < 20 { 0.75 } else { (h & 1023) as f32 / 1023.0 };
        dense.density.set(ijk, v);
    }
    SparseVolume::from_dense(&dense)
}

/// Values equal the trilinear `Sampled` bit for bit and gradients its central
/// differences within f32 rounding, everywhere around and inside the grid
/// (including the stored region's edges and beyond it).
#[test]
fn values_and_gradients_match_the_sampled_field() {
    for (dims, bg) in [
        (UVec3::new(37, 20, 45), 0.0),
        (UVec3::ONE, 0.5),
        (UVec3::new(16, 3, 30), -1.0),
    ] {
        let v = volume(dims, bg);
        let field = Sampled::new(&v, Filter::Trilinear).with_gradient(GradientMethod::CentralDifference);
        let packed = pack(&v).expect("small volume");
        let t = &v.grid.transform;
        let mut next = uniform(12345u64);
        let lo = DVec3::splat(-4.0);
        let hi = dims.as_dvec3() + 4.0;
        for _ in 0..20_000 {
            let index = lo + (hi - lo) * DVec3::new(next(), next(), next());
            let p = t.index_to_world(index);
            assert_eq!(packed.value(p).to_bits(), field.value(p).to_bits(), "{index}");
            let (a, b) = (packed.gradient(p), field.gradient(p));
            let scale = 1.0 + b.abs().max_element();
            assert!((a - b).abs().max_element() <= 1e-6 * scale, "{index}: {a} vs {b}");
        }
        // Whole-voxel positions hit the tile borders exactly.
        for ijk in IndexBox::new(IVec3::splat(-3), dims.as_ivec3() + 3).iter() {
            let p = t.voxel_center(ijk);
            assert_eq!(packed.value(p).to_bits(), field.value(p).to_bits(), "{ijk}");
            let (a, b) = (packed.gradient(p), field.gradient(p));
            assert!(
                (a - b).abs().max_element() <= 1e-6 * (1.0 + b.abs().max_element()),
                "{ijk}"
            );
        }
    }
}

/// The eight-lane fetch equals `sample4` within `f32` rounding of its other
/// blend order, inside, on tile borders, outside the stored region and at
/// non-finite positions (the background with a zero gradient); the AVX2 fetch
/// equals the portable one bit for bit.
#[test]
#[allow(clippy::needless_range_loop)]
fn lane_fetch_matches_the_one_sample_fetch() {
    for (dims, bg) in [
        (UVec3::new(37, 20, 45), 0.0),
        (UVec3::ONE, 0.5),
        (UVec3::new(16, 3, 30), -1.0),
    ] {
        let v = volume(dims, bg);
        let packed = pack(&v).expect("small volume");
        let mut next = uniform(99u64);
        let lo = DVec3::splat(-40.0);
        let hi = dims.as_dvec3() + 40.0;
        let mut lanes_checked = 0;
        for round in 0..4000 {
            let mut pos = [[0.0f32; 8]; 3];
            for l in 0..8 {
                let mut p = lo + (hi - lo) * DVec3::new(next(), next(), next());
                if round % 7 == 0 {
                    p = p.round(); // whole voxels: tile borders and the far corners
                }
                for a in 0..3 {
                    pos[a][l] = p[a] as f32;
                }
            }
            if round == 1 {
                pos[0][1] = f32::NAN;
                pos[1][2] = f32::INFINITY;
                pos[2][3] = f32::NEG_INFINITY;
                pos[0][4] = 3e9;
                pos[1][5] = -3e9;
            }
            let (val, grad) = packed.sample_lanes(&pos);
            for l in 0..8 {
                let p = DVec3::new(pos[0][l] as f64, pos[1][l] as f64, pos[2][l] as f64);
                let expect = if p.is_finite() {
                    packed.sample4(&packed.cell_at_index(p))
                } else {
                    Vec4::new(bg, 0.0, 0.0, 0.0)
                };
                let got = Vec4::new(val[l], grad[0][l], grad[1][l], grad[2][l]);
                let scale = 1.0 + expect.abs().max_element();
                assert!(
                    (got - expect).abs().max_element() <= 4.0 * f32::EPSILON * scale,
                    "{p}: {got} vs {expect}"
                );
                lanes_checked += 1;
            }
            #[cfg(target_arch = "x86_64")]
            if crate::test_cpu::avx2_fma("PackedVolume::sample_lanes_avx2 vs sample_lanes") {
                // SAFETY: AVX2 is present (`avx2_fma` checked).
                let (val2, grad2) = unsafe { packed.sample_lanes_avx2(&pos) };
                assert_eq!(val2.map(f32::to_bits), val.map(f32::to_bits));
                assert_eq!(grad2.map(|g| g.map(f32::to_bits)), grad.map(|g| g.map(f32::to_bits)));
            }
        }
        assert_eq!(lanes_checked, 32_000);
    }
}

#[test]
fn uniform_tiles_share_storage() {
    let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::splat(60)).unwrap();
    let v = SparseVolume::new(grid, 0.0, false);
    let packed = pack(&v).unwrap();
    assert_eq!(packed.voxels.len(), PADDED_VOXELS);
    assert_eq!(packed.table.len(), 4 * 4 * 4);
    assert_eq!(packed.value(DVec3::splat(30.5)), 0.0);
}
