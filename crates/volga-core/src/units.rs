//! "One voxel" in world units: three different lengths, each named.
//!
//! A voxel count becomes a world length in one of three ways, and each tool picks the
//! one its guarantee needs:
//!
//! * [`Transform::voxel_diagonal`] (`‖spacing‖₂`): the oriented box filter's half-width
//!   (Sramek & Kaufman's `√3` voxels on a cubic grid, so central differences over the
//!   3×3×3 neighbourhood see the linear ramp on every axis), and the band of binary
//!   surfaces (every voxel within one N-step of the surface lies within a diagonal).
//! * [`Transform::max_spacing`] (the coarsest axis): distance-field half-widths given in
//!   voxels (`--distance 3` is three voxels on every axis, so the band is at least that
//!   wide along each one), and the sign band of binary solids (one voxel on every axis).
//! * [`Transform::min_spacing`] (the finest axis): converting a world band into a voxel
//!   count for *covering* (how many voxels a band can reach along any axis), so a range
//!   computed from it is a superset on anisotropic grids.
//!
//! On a cubic grid with spacing `h` they are `√3·h`, `h` and `h`.

use crate::{Grid, Transform};

impl Transform {
    /// The voxel diagonal `‖spacing‖₂` (world units): the half-width of the oriented box
    /// filter and the band of binary surfaces (see the module doc of `units`).
    #[inline]
    pub fn voxel_diagonal(&self) -> f64 {
        self.spacing().length()
    }

    /// The largest spacing over the three axes (world units): "n voxels" as a world
    /// length that is at least n voxels along every axis (distance-field bands).
    #[inline]
    pub fn max_spacing(&self) -> f64 {
        self.spacing().max_element()
    }
}

impl Grid {
    /// [`Transform::voxel_diagonal`] of this grid's transform.
    #[inline]
    pub fn voxel_diagonal(&self) -> f64 {
        self.transform.voxel_diagonal()
    }

    /// [`Transform::max_spacing`] of this grid's transform.
    #[inline]
    pub fn max_spacing(&self) -> f64 {
        self.transform.max_spacing()
    }

    /// [`Transform::min_spacing`] of this grid's transform.
    #[inline]
    pub fn min_spacing(&self) -> f64 {
        self.transform.min_spacing()
    }
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, UVec3};

    use crate::{Grid, Transform};

    #[test]
    fn the_three_voxel_lengths() {
        let t = Transform::new(DVec3::ZERO, DVec3::new(2.0, 3.0, 6.0)).unwrap();
        assert_eq!(t.voxel_diagonal(), 7.0);
        assert_eq!(t.max_spacing(), 6.0);
        assert_eq!(t.min_spacing(), 2.0);
        let g = Grid::new(t, UVec3::splat(2)).unwrap();
        assert_eq!((g.voxel_diagonal(), g.max_spacing(), g.min_spacing()), (7.0, 6.0, 2.0));
    }
}
