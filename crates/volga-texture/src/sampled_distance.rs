//! A signed distance sampled on a grid (from [`crate::edt::signed_distance`]), read by
//! trilinear interpolation: the distance source of hypertextures on sampled volumes.

use glam::{DVec3, IVec3};
use volga_core::{Aabb, Grid};
use volga_shapes::DistanceSource;

use crate::TextureError;

/// Signed distances at the voxel centres of `grid` (x fastest). Outside the grid's
/// sampled box the distance is `+∞` (nothing there).
#[derive(Debug, Clone)]
pub struct SampledDistance {
    grid: Grid,
    values: Vec<f64>,
    object: Aabb,
}

impl SampledDistance {
    /// The distances `values`, one per voxel of `grid` (x fastest); refused
    /// ([`TextureError::ValueCount`]) when their number is not the grid's voxel count.
    pub fn new(grid: Grid, values: Vec<f64>) -> Result<Self, TextureError> {
        if values.len() as u64 != grid.voxel_count() {
            return Err(TextureError::ValueCount {
                expected: grid.voxel_count(),
                got: values.len(),
            });
        }
        let mut object = Aabb::EMPTY;
        let d = grid.dims().as_ivec3();
        for z in 0..d.z {
            for y in 0..d.y {
                for x in 0..d.x {
                    let i = (x + d.x * (y + d.y * z)) as usize;
                    if values[i] < 0.0 {
                        let c = grid.transform.voxel_center(IVec3::new(x, y, z));
                        object = object.union(&Aabb::new(c, c));
                    }
                }
            }
        }
        let object = object.expanded(grid.transform.spacing());
        Ok(SampledDistance { grid, values, object })
    }

    fn at(&self, ijk: IVec3) -> f64 {
        let d = self.grid.dims().as_ivec3();
        let c = ijk.clamp(IVec3::ZERO, d - 1);
        self.values[(c.x + d.x * (c.y + d.y * c.z)) as usize]
    }
}

impl DistanceSource for SampledDistance {
    fn distance(&self, p: DVec3) -> f64 {
        if !self.grid.sampled_bounds().contains(p) {
            return f64::INFINITY;
        }
        let q = self.grid.transform.world_to_index(p);
        let base = q.floor();
        let f = q - base;
        let b = base.as_ivec3();
        let mut acc = 0.0;
        for corner in 0..8 {
            let o = IVec3::new(corner & 1, (corner >> 1) & 1, corner >> 2);
            let w = (if o.x == 1 { f.x } else { 1.0 - f.x })
                * (if o.y == 1 { f.y } else { 1.0 - f.y })
                * (if o.z == 1 { f.z } else { 1.0 - f.z });
            if w != 0.0 {
                acc += w * self.at(b + o);
            }
        }
        acc
    }

    /// Trilinear values lie between the samples they read: the min and max of the
    /// samples of every cell the box touches (`+∞` if it leaves the sampled box).
    fn range(&self, world_box: &Aabb) -> (f64, f64) {
        let sampled = self.grid.sampled_bounds();
        let inner = world_box.intersection(&sampled);
        if inner.is_empty() {
            return (f64::INFINITY, f64::INFINITY);
        }
        let t = &self.grid.transform;
        let lo = t.world_to_index(inner.min).floor().as_ivec3();
        let hi = t.world_to_index(inner.max).floor().as_ivec3() + 1;
        let (mut a, mut b) = (f64::INFINITY, f64::NEG_INFINITY);
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let v = self.at(IVec3::new(x, y, z));
                    a = a.min(v);
                    b = b.max(v);
                }
            }
        }
        let leaves = world_box.min.cmplt(sampled.min).any() || world_box.max.cmpgt(sampled.max).any();
        (a, if leaves { f64::INFINITY } else { b })
    }

    fn bounds(&self) -> Aabb {
        self.object
    }

    /// Interpolated samples of a distance transform, not the exact distance.
    fn is_exact(&self) -> bool {
        false
    }
}
