use glam::{DVec3, IVec3, UVec3};

use crate::{Aabb, CoreError, Shape3};

/// World ↔ index mapping: `world = origin + index ⊙ spacing`.
///
/// `origin` is the world position of voxel (0, 0, 0)'s centre; `spacing` is the
/// distance between voxel centres along each axis (anisotropic grids allowed).
/// Both are validated: finite origin, finite positive spacing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    origin: DVec3,
    spacing: DVec3,
}

impl Transform {
    /// The transform with voxel (0, 0, 0)'s centre at `origin` and voxel centres `spacing`
    /// apart along x, y and z (world units).
    ///
    /// Errors: [`CoreError::BadOrigin`] if `origin` is not finite, [`CoreError::BadSpacing`]
    /// if a spacing component is not finite and > 0 (checked in that order).
    pub fn new(origin: DVec3, spacing: DVec3) -> Result<Self, CoreError> {
        if !origin.is_finite() {
            return Err(CoreError::BadOrigin(origin.to_array()));
        }
        if !spacing.is_finite() || spacing.cmple(DVec3::ZERO).any() {
            return Err(CoreError::BadSpacing(spacing.to_array()));
        }
        Ok(Transform { origin, spacing })
    }

    /// World position of voxel (0, 0, 0)'s centre (finite).
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// World distance between neighbouring voxel centres along x, y and z (each positive
    /// and finite).
    pub fn spacing(&self) -> DVec3 {
        self.spacing
    }

    /// Smallest spacing over the three axes (world units).
    pub fn min_spacing(&self) -> f64 {
        self.spacing.min_element()
    }

    /// Continuous index coordinates of a world point.
    #[inline]
    pub fn world_to_index(&self, world_pos: DVec3) -> DVec3 {
        (world_pos - self.origin) / self.spacing
    }

    /// World position of continuous index coordinates (a voxel centre for integers).
    #[inline]
    pub fn index_to_world(&self, index_pos: DVec3) -> DVec3 {
        self.origin + index_pos * self.spacing
    }

    /// World position of voxel `ijk`'s centre.
    #[inline]
    pub fn voxel_center(&self, ijk: IVec3) -> DVec3 {
        self.index_to_world(ijk.as_dvec3())
    }

    /// The voxel whose cell contains `world_pos` (half-open: `floor(index + ½)`).
    #[inline]
    pub fn nearest_voxel(&self, world_pos: DVec3) -> IVec3 {
        let index_pos = self.world_to_index(world_pos);
        clamp_to_ivec3((index_pos + 0.5).map(fast_floor))
    }
}

/// `x.floor()` without a libm call. The workspace builds for baseline x86-64, without
/// SSE4.1's `roundsd`, where `f64::floor` is a function call: it took a tenth of a
/// render's time in the samplers. Truncation by conversion, corrected for negatives:
/// equal to `floor` for |x| < 2⁶³ (every index or lattice coordinate); beyond, it
/// saturates at ±2⁶³, and NaN gives 0.
#[inline]
pub fn fast_floor(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// Converts floored index coordinates to `IVec3`, saturating far outside the `i32`
/// range (such points are outside every grid anyway; NaN maps to 0).
#[inline]
pub(crate) fn clamp_to_ivec3(v: DVec3) -> IVec3 {
    let lim = i32::MAX as f64 / 2.0;
    let c = v.clamp(DVec3::splat(-lim), DVec3::splat(lim));
    IVec3::new(c.x as i32, c.y as i32, c.z as i32)
}

/// A transform plus a voxel extent: voxels `0 ≤ ijk < dims`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Placement of the voxels in world space.
    pub transform: Transform,
    dims: UVec3,
}

impl Grid {
    /// A grid of `dims` voxels (`0 ≤ ijk < dims`) placed by `transform`.
    ///
    /// Errors: [`CoreError::EmptyGrid`] if an axis is 0; [`CoreError::TooLarge`] if an axis
    /// exceeds `i32::MAX / 2` (1 073 741 823) voxels, so voxel coordinates and their
    /// neighbours fit in `i32`. The voxel count is not checked against memory here (see
    /// [`Grid::shape`]).
    pub fn new(transform: Transform, dims: UVec3) -> Result<Self, CoreError> {
        if dims.cmpeq(UVec3::ZERO).any() {
            return Err(CoreError::EmptyGrid(dims.to_array()));
        }
        if dims.cmpgt(UVec3::splat(i32::MAX as u32 / 2)).any() {
            return Err(CoreError::TooLarge {
                dims: dims.to_array(),
                voxels: dims.as_dvec3().element_product() as u128,
            });
        }
        Ok(Grid { transform, dims })
    }

    /// A grid whose voxel cells exactly tile `world_box`, with `dims` voxels per axis.
    pub fn covering(world_box: &Aabb, dims: UVec3) -> Result<Self, CoreError> {
        let spacing = world_box.size() / dims.as_dvec3().max(DVec3::ONE);
        let transform = Transform::new(world_box.min + spacing * 0.5, spacing)?;
        Grid::new(transform, dims)
    }

    /// Number of voxels along x, y and z (each ≥ 1).
    pub fn dims(&self) -> UVec3 {
        self.dims
    }

    /// Total number of voxels (u64: a 2048³ grid overflows u32).
    pub fn voxel_count(&self) -> u64 {
        self.dims.as_u64vec3().element_product()
    }

    /// Dense layout of this grid, if its voxel count fits in `usize`.
    pub fn shape(&self) -> Result<Shape3, CoreError> {
        usize::try_from(self.voxel_count())
            .map(|_| Shape3::new_unchecked(self.dims))
            .map_err(|_| CoreError::TooLarge {
                dims: self.dims.to_array(),
                voxels: self.voxel_count() as u128,
            })
    }

    /// All the grid's voxels: the index box `0 ≤ ijk < dims`.
    pub fn index_box(&self) -> IndexBox {
        IndexBox::new(IVec3::ZERO, self.dims.as_ivec3())
    }

    /// The sub-grid of the voxels in `region` (index space): the same spacing, voxel
    /// (0, 0, 0) at this grid's voxel `region.min`. Errors with
    /// [`CoreError::BadRegion`] unless `0 ≤ min < max ≤ dims` on every axis.
    pub fn window(&self, region: &IndexBox) -> Result<Grid, CoreError> {
        if region.is_empty() || region.min.cmplt(IVec3::ZERO).any() || region.max.cmpgt(self.dims.as_ivec3()).any() {
            return Err(CoreError::BadRegion {
                min: region.min.to_array(),
                max: region.max.to_array(),
                dims: self.dims.to_array(),
            });
        }
        let transform = Transform::new(self.transform.voxel_center(region.min), self.transform.spacing())?;
        Grid::new(transform, (region.max - region.min).as_uvec3())
    }

    /// Whether voxel `ijk` is inside the grid (`0 ≤ ijk < dims`).
    pub fn contains(&self, ijk: IVec3) -> bool {
        self.index_box().contains(ijk)
    }

    /// World box covered by the voxel cells (see the crate doc's convention).
    pub fn world_bounds(&self) -> Aabb {
        Aabb::new(
            self.transform.index_to_world(DVec3::splat(-0.5)),
            self.transform.index_to_world(self.dims.as_dvec3() - 0.5),
        )
    }

    /// World box spanned by the voxel centres: where trilinear reconstruction has
    /// all eight neighbours inside the grid.
    pub fn center_bounds(&self) -> Aabb {
        Aabb::new(
            self.transform.index_to_world(DVec3::ZERO),
            self.transform.index_to_world(self.dims.as_dvec3() - DVec3::ONE),
        )
    }

    /// World box outside which a reconstruction of this grid ([`crate::Sampled`],
    /// nearest or trilinear) equals the background: the voxel centres' box grown by
    /// one spacing. The bounds a renderer clips rays to.
    pub fn sampled_bounds(&self) -> Aabb {
        self.center_bounds().expanded(self.transform.spacing())
    }

    /// Voxels whose centres can influence a trilinear sample inside `world_box`,
    /// clipped to the grid.
    pub fn index_box_touching(&self, world_box: &Aabb) -> IndexBox {
        let lo = self.transform.world_to_index(world_box.min).floor();
        let hi = self.transform.world_to_index(world_box.max).ceil() + DVec3::ONE;
        IndexBox::new(clamp_to_ivec3(lo), clamp_to_ivec3(hi)).intersection(&self.index_box())
    }
}

/// A half-open box of voxel coordinates `min ≤ ijk < max` in **index space**.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct IndexBox {
    /// First voxel of the box on each axis (inclusive).
    pub min: IVec3,
    /// One past the last voxel on each axis (exclusive); `max ≤ min` on any axis makes
    /// the box empty.
    pub max: IVec3,
}

impl IndexBox {
    /// The box `min ≤ ijk < max` as given (not reordered: `max ≤ min` on an axis makes it
    /// empty).
    pub fn new(min: IVec3, max: IVec3) -> Self {
        IndexBox { min, max }
    }

    /// Whether the box holds no voxel (`max ≤ min` on some axis).
    pub fn is_empty(&self) -> bool {
        self.min.cmpge(self.max).any()
    }

    /// Whether voxel `ijk` is in the box (`min` inclusive, `max` exclusive).
    pub fn contains(&self, ijk: IVec3) -> bool {
        ijk.cmpge(self.min).all() && ijk.cmplt(self.max).all()
    }

    /// The voxels in both boxes; empty (possibly with `max < min`) if they are disjoint.
    pub fn intersection(&self, other: &IndexBox) -> IndexBox {
        IndexBox::new(self.min.max(other.min), self.max.min(other.max))
    }

    /// Number of voxels (0 for an empty box).
    pub fn volume(&self) -> u64 {
        if self.is_empty() {
            0
        } else {
            (self.max - self.min).as_u64vec3().element_product()
        }
    }

    /// Every voxel, x fastest, in a fixed order.
    pub fn iter(&self) -> impl Iterator<Item = IVec3> + '_ {
        let b = *self;
        let empty = b.is_empty();
        (b.min.z..if empty { b.min.z } else { b.max.z }).flat_map(move |z| {
            (b.min.y..b.max.y).flat_map(move |y| (b.min.x..b.max.x).map(move |x| IVec3::new(x, y, z)))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_parameters() {
        assert!(Transform::new(DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0)).is_err());
        assert!(Transform::new(DVec3::ZERO, DVec3::new(1.0, -1.0, 1.0)).is_err());
        assert!(Transform::new(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::ONE).is_err());
        let t = Transform::new(DVec3::ZERO, DVec3::ONE).unwrap();
        assert!(Grid::new(t, UVec3::new(4, 0, 4)).is_err());
    }

    #[test]
    fn fast_floor_is_floor() {
        for x in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999,
            -2.999,
            1e15 + 0.5,
            -1e15 - 0.5,
            4.5e15,
            1e-300,
            -1e-300,
        ] {
            assert_eq!(fast_floor(x), x.floor(), "{x}");
        }
        assert_eq!(fast_floor(f64::NAN), 0.0);
        assert_eq!(fast_floor(1e300), 2f64.powi(63));
        assert_eq!(fast_floor(f64::NEG_INFINITY), -(2f64.powi(63)));
    }

    #[test]
    fn nearest_voxel_is_half_open() {
        let t = Transform::new(DVec3::ZERO, DVec3::ONE).unwrap();
        assert_eq!(t.nearest_voxel(DVec3::splat(0.5)), IVec3::ONE);
        assert_eq!(t.nearest_voxel(DVec3::splat(0.4999)), IVec3::ZERO);
        assert_eq!(t.nearest_voxel(DVec3::splat(-0.5)), IVec3::ZERO);
        assert_eq!(t.nearest_voxel(DVec3::splat(-0.5001)), -IVec3::ONE);
    }

    #[test]
    fn covering_grid_tiles_the_box() {
        let b = Aabb::new(DVec3::new(-1.0, -2.0, 0.0), DVec3::new(1.0, 2.0, 3.0));
        let g = Grid::covering(&b, UVec3::new(4, 8, 6)).unwrap();
        assert_eq!(g.world_bounds(), b);
        assert_eq!(g.transform.spacing(), DVec3::splat(0.5));
    }

    #[test]
    fn index_box_iterates_x_fastest() {
        let b = IndexBox::new(IVec3::ZERO, IVec3::new(2, 2, 1));
        let v: Vec<_> = b.iter().collect();
        assert_eq!(
            v,
            vec![
                IVec3::new(0, 0, 0),
                IVec3::new(1, 0, 0),
                IVec3::new(0, 1, 0),
                IVec3::new(1, 1, 0)
            ]
        );
        assert_eq!(IndexBox::new(IVec3::ONE, IVec3::ZERO).iter().count(), 0);
    }
}
