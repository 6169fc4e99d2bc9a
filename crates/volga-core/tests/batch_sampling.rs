//! The batch sampling path of `Sampled` (`values_along`, `gradient`, `gradients_at`,
//! through the brick-caching `SparseReader`) against the one-point path: the same
//! values up to the rounding of positions, and the same bits however a line is cut
//! into batches (what makes the renderer's empty-space skipping exact).

mod common;

use glam::{DVec3, IVec3, UVec3};
use proptest::prelude::*;
use volga_core::{Aabb, DenseVolume, Field, Filter, Line, Sampled, SparseVolume, VoxelReader, VoxelSource};

/// A 19×17×11 volume (bricks cut by the grid's end on every axis): a uniform region
/// (x < 8), empty voxels and noise, so uniform, dense and absent bricks all occur.
fn volumes(seed: u64) -> (DenseVolume, SparseVolume) {
    common::random_volumes(seed, UVec3::new(19, 17, 11), 0.4)
}

/// The field of `inner` with the trait's default batch methods and gradient: one
/// `value` per point, central differences one voxel apart in world space.
struct OnePoint<F>(F);
impl<F: Field> Field for OnePoint<F> {
    fn bounds(&self) -> Aabb {
        self.0.bounds()
    }
    fn value(&self, p: DVec3) -> f64 {
        self.0.value(p)
    }
    fn gradient_step(&self) -> DVec3 {
        self.0.gradient_step()
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        self.0.value_range(b)
    }
}

proptest! {
    #[test]
    fn values_along_match_value_and_do_not_depend_on_batching(
        seed in any::<u64>(),
        origin in (-6.0f64..8.0, -1.0f64..7.0, -2.0f64..13.0),
        step in (-0.7f64..0.7, -0.7f64..0.7, -0.7f64..0.7),
        first in 0u64..40,
        cut in 1usize..47,
    ) {
        let (dense, sparse) = volumes(seed);
        let line = Line { origin: DVec3::new(origin.0, origin.1, origin.2), step: DVec3::new(step.0, step.1, step.2) };
        const N: usize = 48;
        for filter in [Filter::Nearest, Filter::Trilinear] {
            let (fd, fs) = (Sampled::new(&dense, filter), Sampled::new(&sparse, filter));
            let mut whole = [0.0; N];
            fs.values_along(&line, first, &mut whole);
            // Cut into two batches: the same bits.
            let mut parts = [0.0; N];
            fs.values_along(&line, first, &mut parts[..cut]);
            fs.values_along(&line, first + cut as u64, &mut parts[cut..]);
            prop_assert_eq!(whole.map(f64::to_bits), parts.map(f64::to_bits));
            // Dense storage gives the same bits as sparse.
            let mut from_dense = [0.0; N];
            fd.values_along(&line, first, &mut from_dense);
            prop_assert_eq!(whole.map(f64::to_bits), from_dense.map(f64::to_bits));
            // The default (one `value` per point) agrees with the batch path up to the
            // rounding of the position: trilinear values within 1e-9 (slopes of at most
            // 4 per world unit, positions off by ulps); nearest, the same voxel except
            // within rounding of a cell border.
            let mut one_point = [0.0; N];
            OnePoint(Sampled::new(&sparse, filter)).values_along(&line, first, &mut one_point);
            for (k, (v, one)) in whole.iter().zip(&one_point).enumerate() {
                let p = line.at(first + k as u64);
                prop_assert_eq!(*one, fs.value(p));
                if filter == Filter::Trilinear {
                    prop_assert!((v - one).abs() < 1e-9, "{} vs {} at {}", v, one, p);
                } else if v != one {
                    let index = sparse.grid.transform.world_to_index(p) + 0.5;
                    let to_border = (index - index.round()).abs().min_element();
                    prop_assert!(to_border < 1e-9, "{} vs {} at {}", v, one, p);
                }
            }
        }
    }

    #[test]
    fn gradients_match_world_central_differences(
        seed in any::<u64>(),
        points in prop::collection::vec((-4.0f64..7.0, 0.0f64..6.0, -1.0f64..12.0), 16),
    ) {
        let (dense, sparse) = volumes(seed);
        let fs = Sampled::new(&sparse, Filter::Trilinear);
        let reference = OnePoint(Sampled::new(&dense, Filter::Trilinear));
        let world: Vec<DVec3> = points.iter().map(|&(x, y, z)| DVec3::new(x, y, z)).collect();
        let mut batch = vec![DVec3::ZERO; world.len()];
        fs.gradients_at(&world, &mut batch);
        for (p, g) in world.iter().zip(&batch) {
            prop_assert_eq!(*g, fs.gradient(*p));
            // Index-space ±1 voxel is world ±spacing: equal up to rounding (values in
            // [0, 1], spacings ≥ 0.25, so ulps of position stay below 1e-9).
            let want = reference.gradient(*p);
            prop_assert!((*g - want).abs().max_element() < 1e-9, "{} vs {} at {}", g, want, p);
        }
    }
}

/// The sparse reader returns the voxels and 2×2×2 cubes of the volume itself, inside,
/// across brick seams (its cache holds the eight bricks around a seam) and outside.
#[test]
fn sparse_reader_reads_what_the_volume_holds() {
    let (dense, sparse) = volumes(7);
    let mut sparse_reader = sparse.reader();
    let mut dense_reader = dense.reader();
    for z in -2..13 {
        for y in -2..19 {
            for x in -2..21 {
                let ijk = IVec3::new(x, y, z);
                let want = VoxelSource::density_cube(&dense, ijk);
                assert_eq!(sparse_reader.density(ijk), dense.density.get(ijk), "{ijk}");
                assert_eq!(sparse_reader.density_cube(ijk), want, "{ijk}");
                assert_eq!(dense_reader.density_cube(ijk), want, "{ijk}");
            }
        }
    }
}

proptest! {
    /// `read_box` (whole rows per brick for a sparse volume) equals `density` voxel by
    /// voxel, for boxes inside, across and beyond the grid's end.
    #[test]
    fn read_box_equals_density_voxel_by_voxel(
        seed in any::<u64>(),
        min in (-10i32..20, -10i32..18, -10i32..12),
        size in (0i32..14, 0i32..14, 0i32..14),
    ) {
        let (dense, sparse) = volumes(seed);
        let index_box = volga_core::IndexBox::new(
            IVec3::new(min.0, min.1, min.2),
            IVec3::new(min.0 + size.0, min.1 + size.1, min.2 + size.2),
        );
        for source in [&dense as &dyn ReadBoth, &sparse] {
            let mut out = vec![f32::NAN; index_box.volume() as usize];
            source.read(&index_box, &mut out);
            for (k, ijk) in index_box.iter().enumerate() {
                prop_assert_eq!(out[k].to_bits(), source.one(ijk).to_bits(), "{:?}", ijk);
            }
        }
    }
}

/// `read_box` and `density` of either volume, object safe.
trait ReadBoth {
    fn read(&self, index_box: &volga_core::IndexBox, out: &mut [f32]);
    fn one(&self, ijk: IVec3) -> f32;
}
impl<S: VoxelSource> ReadBoth for S {
    fn read(&self, index_box: &volga_core::IndexBox, out: &mut [f32]) {
        self.read_box(index_box, out)
    }
    fn one(&self, ijk: IVec3) -> f32 {
        self.density(ijk)
    }
}
