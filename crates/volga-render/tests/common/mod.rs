//! Volumes and a generator shared by the packed-path tests (`packed.rs`, `iso_packed.rs`).

use glam::{DVec3, UVec3};
use volga_core::{DenseVolume, Grid, SparseVolume, Transform};

/// A small deterministic generator (LCG), so random views are fixed.
pub struct Lcg(pub u64);
impl Lcg {
    /// The next number in [0, 1).
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A volume on `grid` whose voxel `ijk` holds `density` at `ijk / (dims − 1)`.
pub fn volume_from(grid: Grid, density: impl Fn(DVec3) -> f32) -> SparseVolume {
    let mut dense = DenseVolume::new(grid, 0.0, false).unwrap();
    for ijk in grid.index_box().iter() {
        dense
            .density
            .set(ijk, density(ijk.as_dvec3() / (grid.dims().as_dvec3() - 1.0)));
    }
    SparseVolume::from_dense(&dense)
}

/// Nested blended ellipsoids (skin 0.3, skull 1, brain 0.4, a lesion 0.6) on [0, 1]³.
pub fn phantom() -> SparseVolume {
    let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::new(40, 44, 36)).unwrap();
    let parts = [
        (DVec3::splat(0.5), DVec3::new(0.4, 0.45, 0.42), 0.3f32),
        (DVec3::splat(0.5), DVec3::new(0.36, 0.41, 0.38), 1.0),
        (DVec3::splat(0.5), DVec3::new(0.32, 0.37, 0.34), 0.4),
        (DVec3::new(0.55, 0.4, 0.6), DVec3::splat(0.08), 0.6),
    ];
    volume_from(grid, |p| {
        let mut d = 0.0f32;
        for (c, r, v) in parts {
            let q = ((p - c) / r).length() - 1.0;
            let t = (0.5 - q * 8.0).clamp(0.0, 1.0) as f32;
            d += (v - d) * t * t * (3.0 - 2.0 * t);
        }
        d
    })
}

/// A ball with a tunnel and hash noise in its shell, on an anisotropic grid far from
/// the origin (origin at 1e5).
pub fn blob() -> SparseVolume {
    let grid = Grid::new(
        Transform::new(DVec3::splat(1e5), DVec3::new(0.5, 0.75, 0.6)).unwrap(),
        UVec3::new(38, 30, 33),
    )
    .unwrap();
    volume_from(grid, |p| {
        let q = p - 0.5;
        let shell = (0.5 - (q.length() - 0.35) * 20.0).clamp(0.0, 1.0);
        let tunnel = ((q.x * q.x + q.y * q.y).sqrt() < 0.12) as u8 as f64;
        let h = ((p.x * 7919.0).sin() * (p.y * 104_729.0).cos() * (p.z * 1299.0).sin()).abs();
        ((shell * (1.0 - tunnel)) * (0.8 + 0.2 * h)) as f32
    })
}
