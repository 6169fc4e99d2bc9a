use glam::IVec3;

use crate::{CoreError, Grid, Rgb, Shape3};

/// A dense 3D array of `T` over a [`Shape3`]; reads outside return `background`.
#[derive(Debug, Clone, PartialEq)]
pub struct Dense<T> {
    shape: Shape3,
    data: Vec<T>,
    background: T,
}

impl<T: Copy + Send + Sync> Dense<T> {
    /// An array of `shape` with every element `value`, reading `background` outside it.
    /// Allocates `shape.len()` elements.
    pub fn filled(shape: Shape3, value: T, background: T) -> Self {
        Dense {
            shape,
            data: vec![value; shape.len()],
            background,
        }
    }

    /// The array's dims and layout.
    pub fn shape(&self) -> Shape3 {
        self.shape
    }

    /// The value [`Dense::get`] returns outside the array.
    pub fn background(&self) -> T {
        self.background
    }

    /// The values, x fastest ([`Shape3::linearize`] order).
    pub fn as_slice(&self) -> &[T] {
        &self.data
    }

    /// The values (x fastest, [`Shape3`]'s layout), without a copy.
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }

    /// The values for writing, x fastest ([`Shape3::linearize`] order).
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// The value at `ijk`, or the background outside `0 ≤ ijk < dims`.
    #[inline]
    pub fn get(&self, ijk: IVec3) -> T {
        if self.shape.contains(ijk) {
            self.data[self.shape.linearize(ijk)]
        } else {
            self.background
        }
    }

    /// Writes `value` at `ijk`; writes outside the array are ignored and return false.
    #[inline]
    pub fn set(&mut self, ijk: IVec3, value: T) -> bool {
        if self.shape.contains(ijk) {
            let i = self.shape.linearize(ijk);
            self.data[i] = value;
            true
        } else {
            false
        }
    }
}

/// A volume stored voxel by voxel: for small grids, tests and exchange.
///
/// The density channel always exists; the colour channel exists only when asked for,
/// so a build that never reads colour never pays for it.
#[derive(Debug, Clone, PartialEq)]
pub struct DenseVolume {
    /// Placement and extent; [`DenseVolume::new`] gives both channels its dims.
    pub grid: Grid,
    /// The scalar channel, one value per voxel; reads outside the grid return its
    /// background (the `background` passed to [`DenseVolume::new`]).
    pub density: Dense<f32>,
    /// Linear RGB per voxel, each component in \[0, 1\]; present only for a volume made
    /// `with_colour`, black where not written and outside the grid.
    pub colour: Option<Dense<Rgb>>,
}

impl DenseVolume {
    /// A volume filled with `background` density (and black colour if `with_colour`).
    pub fn new(grid: Grid, background: f32, with_colour: bool) -> Result<Self, CoreError> {
        let shape = grid.shape()?;
        Ok(DenseVolume {
            grid,
            density: Dense::filled(shape, background, background),
            colour: with_colour.then(|| Dense::filled(shape, [0.0; 3], [0.0; 3])),
        })
    }

    /// Bytes of payload this volume holds.
    pub fn payload_bytes(&self) -> u64 {
        let n = self.grid.voxel_count();
        n * 4 + if self.colour.is_some() { n * 12 } else { 0 }
    }
}
