use glam::{IVec3, UVec3};

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

    pub fn dims(&self) -> UVec3 {
        self.dims
    }

    pub fn len(&self) -> usize {
        self.dims.x as usize * self.dims.y as usize * self.dims.z as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

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
    }
}
