//! The reconstruction filters (nearest, trilinear, Catmull–Rom, B-spline) and both
//! gradient methods: the cubics read across brick seams and the grid's faces exactly as
//! over a dense copy, every path (one point, batches, the prepared atlas) gives the same
//! bits, Catmull–Rom interpolates the voxels, linear signals are reproduced exactly by
//! every filter but nearest, analytic derivatives match finite differences of the
//! reconstruction, and value ranges bound every sample.

mod common;

use glam::{DVec3, UVec3};
use proptest::prelude::*;
use volga_core::{Aabb, DenseVolume, Field, Filter, GradientMethod, Grid, Line, Sampled, SparseVolume, Transform};

/// A 21×18×13 volume (bricks cut by the grid's end, seams on every axis): a uniform
/// region, empty voxels and noise.
fn volumes(seed: u64) -> (DenseVolume, SparseVolume) {
    common::random_volumes(seed | 1, UVec3::new(21, 18, 13), 0.3)
}

fn combos() -> Vec<(Filter, GradientMethod)> {
    Filter::ALL
        .iter()
        .flat_map(|f| GradientMethod::ALL.iter().map(move |g| (*f, *g)))
        .collect()
}

fn bits(v: DVec3) -> [u64; 3] {
    v.to_array().map(f64::to_bits)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Points anywhere in and around the grid (brick seams at index multiples of 8,
    /// the faces and the apron beyond them): sparse, dense and the prepared atlas give
    /// the same bits for values, batches and gradients of every filter and method.
    #[test]
    fn sparse_dense_and_prepared_agree_bit_for_bit(seed in any::<u64>(), u in prop::array::uniform3(-0.2f64..1.2)) {
        let (dense, sparse) = volumes(seed);
        let bounds = dense.grid.sampled_bounds().expanded(DVec3::ONE);
        let p = bounds.min + bounds.size() * DVec3::from(u);
        for (filter, method) in combos() {
            let s = Sampled::new(&sparse, filter).with_gradient(method);
            let d = Sampled::new(&dense, filter).with_gradient(method);
            let prepared = s.prepare().expect("small atlas");
            prop_assert_eq!(s.value(p).to_bits(), d.value(p).to_bits());
            prop_assert_eq!(s.value(p).to_bits(), prepared.value(p).to_bits());
            prop_assert_eq!(bits(s.gradient(p)), bits(d.gradient(p)));
            prop_assert_eq!(bits(s.gradient(p)), bits(prepared.gradient(p)));
            let line = Line { origin: p, step: DVec3::new(0.31, -0.07, 0.45) };
            let (mut a, mut b, mut c) = ([0.0; 12], [0.0; 12], [0.0; 12]);
            s.values_along(&line, 3, &mut a);
            d.values_along(&line, 3, &mut b);
            prepared.values_along(&line, 3, &mut c);
            prop_assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
            prop_assert_eq!(a.map(f64::to_bits), c.map(f64::to_bits));
        }
    }

    /// A box's value range bounds every sample in it (cubic overshoot, background
    /// beyond the faces and the filters' reach included).
    #[test]
    fn value_ranges_bound_the_samples(seed in any::<u64>(), u in prop::array::uniform3(0.0f64..1.0), e in prop::array::uniform3(0.0f64..0.25)) {
        let (_, sparse) = volumes(seed);
        let bounds = sparse.grid.sampled_bounds().expanded(DVec3::splat(1.5));
        let lo = bounds.min + bounds.size() * DVec3::from(u);
        let b = Aabb::new(lo, lo + bounds.size() * DVec3::from(e));
        for filter in Filter::ALL {
            let f = Sampled::new(&sparse, filter);
            let (rlo, rhi) = f.value_range(&b);
            for i in 0..125 {
                let t = DVec3::new((i % 5) as f64, ((i / 5) % 5) as f64, (i / 25) as f64) / 4.0;
                let v = f.value(b.min + b.size() * t);
                prop_assert!(rlo <= v && v <= rhi, "{:?}: {} outside [{}, {}]", filter, v, rlo, rhi);
            }
            // Beyond the bounds the field is the background.
            let outside = f.bounds().max + DVec3::splat(1e-9);
            prop_assert_eq!(f.value(outside), 0.0);
        }
    }
}

/// Catmull–Rom passes through the voxel values; the B-spline smooths them.
#[test]
fn catmull_rom_interpolates_the_voxels() {
    let (dense, _) = volumes(7);
    let f = Sampled::new(&dense, Filter::CatmullRom);
    let b = Sampled::new(&dense, Filter::BSpline);
    let mut smoothed = 0;
    for ijk in dense.grid.index_box().iter() {
        let p = dense.grid.transform.voxel_center(ijk);
        let v = dense.density.get(ijk) as f64;
        assert!((f.value(p) - v).abs() < 1e-12, "{ijk}");
        smoothed += ((b.value(p) - v).abs() > 1e-6) as u32;
    }
    assert!(smoothed > 100, "{smoothed}");
}

/// A linear signal `a + g·p` is reproduced exactly (up to rounding) by trilinear and
/// both cubics, with the exact gradient by either method, away from the faces.
#[test]
fn linear_signals_are_reproduced() {
    let transform = Transform::new(DVec3::new(2.0, -1.0, 0.25), DVec3::new(0.5, 0.25, 1.0)).unwrap();
    let grid = Grid::new(transform, UVec3::new(20, 20, 20)).unwrap();
    let g = DVec3::new(0.01, -0.02, 0.015);
    let signal = |p: DVec3| 0.5 + g.dot(p - DVec3::new(6.0, 1.5, 10.0));
    let mut dense = DenseVolume::new(grid, 0.0, false).unwrap();
    for ijk in grid.index_box().iter() {
        dense.density.set(ijk, signal(transform.voxel_center(ijk)) as f32);
    }
    let sparse = SparseVolume::from_dense(&dense);
    for filter in [Filter::Trilinear, Filter::CatmullRom, Filter::BSpline] {
        for method in GradientMethod::ALL {
            let f = Sampled::new(&sparse, filter).with_gradient(method);
            for k in 0..200 {
                let t = DVec3::new(
                    (k as f64 * 0.37).fract(),
                    (k as f64 * 0.61).fract(),
                    (k as f64 * 0.83).fract(),
                );
                let index_pos = DVec3::splat(3.0) + t * 13.0;
                let p = transform.index_to_world(index_pos);
                // f32 payloads: the voxel values carry rounding of ~3e-8.
                assert!((f.value(p) - signal(p)).abs() < 1e-6, "{filter:?} {p}");
                assert!(
                    (f.gradient(p) - g).length() < 1e-5,
                    "{filter:?} {method:?} {p}: {}",
                    f.gradient(p)
                );
            }
        }
    }
}

/// The analytic derivative is the derivative of the reconstruction: it matches a fine
/// central difference of `value` (inside a cell for trilinear, whose derivative jumps
/// across cell faces), and nearest's is zero.
#[test]
fn analytic_gradients_are_derivatives_of_the_reconstruction() {
    let (dense, _) = volumes(11);
    let tr = dense.grid.transform;
    for filter in [Filter::Trilinear, Filter::CatmullRom, Filter::BSpline] {
        let f = Sampled::new(&dense, filter).with_gradient(GradientMethod::Analytic);
        for k in 0..300 {
            let t = DVec3::new(
                (k as f64 * 0.29).fract(),
                (k as f64 * 0.53).fract(),
                (k as f64 * 0.71).fract(),
            );
            // Fractions kept away from cell faces, so h stays in one cell.
            let index_pos = DVec3::new(4.0, 3.0, 2.0) + (k % 9) as f64 + 0.05 + 0.9 * t;
            let p = tr.index_to_world(index_pos);
            let h = 1e-6;
            let fd = DVec3::new(
                f.value(p + DVec3::X * h) - f.value(p - DVec3::X * h),
                f.value(p + DVec3::Y * h) - f.value(p - DVec3::Y * h),
                f.value(p + DVec3::Z * h) - f.value(p - DVec3::Z * h),
            ) / (2.0 * h);
            let g = f.gradient(p);
            assert!(
                (g - fd).length() < 1e-5 * (1.0 + g.length()),
                "{filter:?} {p}: {g} vs {fd}"
            );
        }
    }
    let nearest = Sampled::new(&dense, Filter::Nearest).with_gradient(GradientMethod::Analytic);
    assert_eq!(nearest.gradient(DVec3::new(1.0, 3.0, 4.0)), DVec3::ZERO);
}
