//! Reconstruction: trilinear sampling reproduces linear fields exactly; sparse and
//! dense volumes sample identically; value ranges are conservative.

use glam::{DVec3, IVec3, UVec3};
use proptest::prelude::*;
use volga::{DenseVolume, Field, Filter, Grid, IndexBox, Sampled, SparseVolume, Transform};

fn grid(origin: DVec3, spacing: DVec3, dims: UVec3) -> Grid {
    Grid::new(Transform::new(origin, spacing).unwrap(), dims).unwrap()
}

/// A dense volume holding `f(index)` at every voxel.
fn fill(grid: Grid, mut f: impl FnMut(IVec3) -> f32) -> DenseVolume {
    let mut v = DenseVolume::new(grid, 0.0, false).unwrap();
    for ijk in grid.index_box().iter() {
        v.density.set(ijk, f(ijk));
    }
    v
}

proptest! {
    /// Linear functions with small integer coefficients are stored exactly in f32 and
    /// interpolated in f64 at dyadic positions, so the result is exact bit for bit.
    #[test]
    fn trilinear_reproduces_linear_fields_exactly(
        a in -8i32..8, b in -8i32..8, c in -8i32..8, d in -64i32..64,
        fx in 0u32..64, fy in 0u32..64, fz in 0u32..64,
        cell in (0i32..14, 0i32..14, 0i32..14),
    ) {
        let g = grid(DVec3::new(-2.0, 3.0, 0.5), DVec3::new(0.5, 0.25, 2.0), UVec3::new(16, 16, 16));
        let lin = |p: DVec3| a as f64 * p.x + b as f64 * p.y + c as f64 * p.z + d as f64;
        let vol = fill(g, |ijk| lin(ijk.as_dvec3()) as f32);
        let index = DVec3::new(cell.0 as f64 + fx as f64 / 64.0, cell.1 as f64 + fy as f64 / 64.0, cell.2 as f64 + fz as f64 / 64.0);
        let world = g.transform.index_to_world(index);
        let sparse = SparseVolume::from_dense(&vol);
        prop_assert_eq!(Sampled::new(&vol, Filter::Trilinear).value(world), lin(index));
        prop_assert_eq!(Sampled::new(&sparse, Filter::Trilinear).value(world), lin(index));
    }

    /// Sparse and dense storage of the same voxels give identical samples, gradients,
    /// colours and value ranges, everywhere (inside, at brick seams, outside the grid).
    #[test]
    fn sparse_and_dense_sample_identically(
        seed in any::<u64>(),
        points in prop::collection::vec((-3.0f64..22.0, -3.0f64..22.0, -3.0f64..14.0), 32),
    ) {
        let g = grid(DVec3::ZERO, DVec3::ONE, UVec3::new(19, 17, 11));
        let mut dense = DenseVolume::new(g, 0.0, true).unwrap();
        let mut state = seed;
        let mut next = || { state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); (state >> 40) as f32 / (1u64 << 24) as f32 };
        for ijk in g.index_box().iter() {
            // Whole uniform regions (x < 8) and noisy ones, so both brick kinds occur.
            let v = if ijk.x < 8 { 0.75 } else if next() < 0.5 { 0.0 } else { next() };
            dense.density.set(ijk, v);
            dense.colour.as_mut().unwrap().set(ijk, [next(), 0.5, v]);
        }
        let sparse = SparseVolume::from_dense(&dense);
        prop_assert!(sparse.density.dense_brick_count() < sparse.density.brick_count());
        for filter in [Filter::Nearest, Filter::Trilinear] {
            let (fd, fs) = (Sampled::new(&dense, filter), Sampled::new(&sparse, filter));
            for &(x, y, z) in &points {
                let p = DVec3::new(x, y, z);
                prop_assert_eq!(fd.value(p), fs.value(p));
                prop_assert_eq!(fd.gradient(p), fs.gradient(p));
                prop_assert_eq!(fd.colour(p), fs.colour(p));
                let b = volga::Aabb::new(p, p + DVec3::new(2.5, 1.0, 3.0));
                prop_assert_eq!(fd.value_range(&b), fs.value_range(&b));
            }
        }
    }

    /// `value_range` contains every value sampled inside the box.
    #[test]
    fn value_range_is_conservative(seed in any::<u64>(), lo in (-2.0f64..20.0, -2.0f64..20.0, -2.0f64..20.0), size in (0.0f64..6.0, 0.0f64..6.0, 0.0f64..6.0)) {
        let g = grid(DVec3::ZERO, DVec3::ONE, UVec3::splat(18));
        let mut s = seed;
        let vol = fill(g, |_| { s ^= s << 13; s ^= s >> 7; s ^= s << 17; (s % 1000) as f32 / 1000.0 });
        let sparse = SparseVolume::from_dense(&vol);
        let f = Sampled::new(&sparse, Filter::Trilinear);
        let lo = DVec3::new(lo.0, lo.1, lo.2);
        let b = volga::Aabb::new(lo, lo + DVec3::new(size.0, size.1, size.2));
        let (rmin, rmax) = f.value_range(&b);
        for k in 0..64 {
            let t = DVec3::new((k % 4) as f64 / 3.0, ((k / 4) % 4) as f64 / 3.0, (k / 16) as f64 / 3.0);
            let v = f.value(b.min + (b.max - b.min) * t);
            prop_assert!(rmin <= v && v <= rmax, "{} not in [{}, {}]", v, rmin, rmax);
        }
    }
}

#[test]
fn central_difference_gradient_of_linear_field() {
    let g = grid(DVec3::ZERO, DVec3::new(0.5, 1.0, 2.0), UVec3::splat(12));
    let vol = fill(g, |ijk| (ijk.x * 3 - ijk.y + 2 * ijk.z) as f32);
    let f = Sampled::new(&vol, Filter::Trilinear);
    // d/dworld of (3 i − j + 2 k) with i = x/0.5, j = y/1, k = z/2.
    let grad = f.gradient(g.transform.index_to_world(DVec3::new(5.25, 6.5, 4.75)));
    assert_eq!(grad, DVec3::new(6.0, -1.0, 1.0));
}

#[test]
fn outside_the_grid_is_background() {
    let g = grid(DVec3::ZERO, DVec3::ONE, UVec3::splat(4));
    let vol = fill(g, |_| 1.0);
    let f = Sampled::new(&vol, Filter::Trilinear);
    assert_eq!(f.value(DVec3::splat(-1.0)), 0.0);
    assert_eq!(f.value(DVec3::new(-0.5, 1.0, 1.0)), 0.5);
    assert_eq!(f.value(DVec3::splat(1.5)), 1.0);
    let n = Sampled::new(&vol, Filter::Nearest);
    assert_eq!(
        n.value(DVec3::new(-0.5, 1.0, 1.0)),
        1.0,
        "half-open: -0.5 belongs to voxel 0"
    );
    assert_eq!(n.value(DVec3::new(-0.51, 1.0, 1.0)), 0.0);
    assert_eq!(IndexBox::new(IVec3::ZERO, IVec3::ONE).volume(), 1);
}
