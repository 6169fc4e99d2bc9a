use glam::{IVec3, UVec3};

use crate::CoreError;

/// Layout of a dense 3D array with x varying fastest:
/// `linear = x + dims.x · (y + dims.y · z)`.
///
/// Every dense buffer in volga goes through this type, so index arithmetic lives in
/// one place (ndshape's habit).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shape3 {
    dims: UVec3,
}

impl Shape3 {
    /// `dims` must be ≥ 1 on every axis and the product must fit in `usize`;
    /// callers (`Grid`) have checked both.
    pub(crate) const fn new_unchecked(dims: UVec3) -> Self {
        Shape3 { dims }
    }

    /// The layout of a `dims` array: refused if an axis is 0 or the voxel count does not
    /// fit in `usize`.
    pub fn new(dims: UVec3) -> Result<Self, CoreError> {
        if dims.cmpeq(UVec3::ZERO).any() {
            return Err(CoreError::EmptyGrid(dims.to_array()));
        }
        let count = dims
            .as_u64vec3()
            .to_array()
            .iter()
            .try_fold(1u64, |a, &d| a.checked_mul(d));
        match count.map(usize::try_from) {
            Some(Ok(_)) => Ok(Shape3 { dims }),
            _ => Err(CoreError::TooLarge {
                dims: dims.to_array(),
                voxels: dims.as_u64vec3().to_array().iter().map(|&d| d as u128).product(),
            }),
        }
    }

    /// Number of elements along x, y and z (each ≥ 1).
    pub fn dims(&self) -> UVec3 {
        self.dims
    }

    /// Number of elements, `dims.x · dims.y · dims.z` (fits in `usize` by construction).
    pub fn len(&self) -> usize {
        self.dims.x as usize * self.dims.y as usize * self.dims.z as usize
    }

    /// Whether the layout holds no element: always false, as every `Shape3` has at least
    /// one element per axis.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether `ijk` is inside the array: `0 ≤ ijk < dims` on every axis.
    pub fn contains(&self, ijk: IVec3) -> bool {
        ijk.cmpge(IVec3::ZERO).all() && ijk.as_uvec3().cmplt(self.dims).all()
    }

    /// Linear offset of `ijk`; `ijk` must be inside (debug-asserted).
    #[inline]
    pub fn linearize(&self, ijk: IVec3) -> usize {
        debug_assert!(self.contains(ijk), "{ijk} outside {}", self.dims);
        let (x, y, z) = (ijk.x as usize, ijk.y as usize, ijk.z as usize);
        x + self.dims.x as usize * (y + self.dims.y as usize * z)
    }

    /// Elements in one z slab (`dims.x · dims.y`): slab `z` is `z · plane_len ..`.
    #[inline]
    pub fn plane_len(&self) -> usize {
        self.dims.x as usize * self.dims.y as usize
    }

    /// Number of x rows (`dims.y · dims.z`).
    #[inline]
    pub fn row_count(&self) -> usize {
        self.dims.y as usize * self.dims.z as usize
    }

    /// Index of the x row holding `ijk` (`y + dims.y · z`); row `r` is the elements
    /// `r · dims.x ..` (so `linearize(ijk) = x + dims.x · row(ijk)`). `ijk.y`, `ijk.z`
    /// must be inside (debug-asserted).
    #[inline]
    pub fn row(&self, ijk: IVec3) -> usize {
        debug_assert!(
            self.contains(IVec3::new(0, ijk.y, ijk.z)),
            "{ijk} outside {}",
            self.dims
        );
        ijk.y as usize + self.dims.y as usize * ijk.z as usize
    }

    /// `(x, row)` of a linear offset: the inverse of `x + dims.x · row` (see
    /// [`Shape3::row`]).
    #[inline]
    pub fn split_row(&self, linear: usize) -> (usize, usize) {
        let nx = self.dims.x as usize;
        (linear % nx, linear / nx)
    }

    /// Inverse of [`Shape3::linearize`].
    #[inline]
    pub fn delinearize(&self, linear: usize) -> IVec3 {
        let nx = self.dims.x as usize;
        let ny = self.dims.y as usize;
        IVec3::new(
            (linear % nx) as i32,
            ((linear / nx) % ny) as i32,
            (linear / (nx * ny)) as i32,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linearize_round_trip() {
        let s = Shape3::new_unchecked(UVec3::new(3, 5, 7));
        for i in 0..s.len() {
            assert_eq!(s.linearize(s.delinearize(i)), i);
        }
        assert_eq!(s.linearize(IVec3::new(1, 0, 0)), 1);
        assert_eq!(s.linearize(IVec3::new(0, 1, 0)), 3);
        assert_eq!(s.linearize(IVec3::new(0, 0, 1)), 15);
        assert_eq!(s.plane_len(), 15);
        assert_eq!(s.row_count(), 35);
        for i in 0..s.len() {
            let v = s.delinearize(i);
            assert_eq!(v.x as usize + 3 * s.row(v), i);
            assert_eq!(s.split_row(i), (v.x as usize, s.row(v)));
        }
    }

    #[test]
    fn new_refuses_empty_and_unaddressable() {
        assert_eq!(Shape3::new(UVec3::new(3, 5, 7)).unwrap().len(), 105);
        assert!(matches!(Shape3::new(UVec3::new(3, 0, 7)), Err(CoreError::EmptyGrid(_))));
        assert!(matches!(
            Shape3::new(UVec3::splat(u32::MAX)),
            Err(CoreError::TooLarge { .. })
        ));
    }
}
