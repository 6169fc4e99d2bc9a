use glam::{DVec3, IVec3, Vec3};

use crate::grid::clamp_to_ivec3;
use crate::sparse::brick_of;
use crate::{Aabb, Brick, DenseVolume, Field, Grid, IndexBox, Rgb, SparseVolume, BRICK_DIM};

/// Reconstruction filter used between voxel centres (survey §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Filter {
    /// The value of the voxel whose cell contains the point (half-open rule).
    Nearest,
    /// Trilinear interpolation of the eight surrounding voxel centres.
    #[default]
    Trilinear,
}

/// Voxel storage that [`Sampled`] can reconstruct from. Reads outside the grid
/// return the background value.
pub trait VoxelSource: Sync {
    fn grid(&self) -> &Grid;
    fn background(&self) -> f32;
    fn density(&self, ijk: IVec3) -> f32;
    /// The 2×2×2 densities at `base + {0,1}³`, x fastest.
    fn density_cube(&self, base: IVec3) -> [f32; 8] {
        std::array::from_fn(|c| self.density(base + corner(c)))
    }
    /// `(min, max)` density over the voxels of `index_box`, already clipped to the grid.
    fn density_range(&self, index_box: &IndexBox) -> (f32, f32);
    fn has_colour(&self) -> bool;
    fn colour(&self, ijk: IVec3) -> Rgb;
}

#[inline]
fn corner(c: usize) -> IVec3 {
    IVec3::new((c & 1) as i32, ((c >> 1) & 1) as i32, ((c >> 2) & 1) as i32)
}

impl VoxelSource for DenseVolume {
    fn grid(&self) -> &Grid {
        &self.grid
    }
    fn background(&self) -> f32 {
        self.density.background()
    }
    #[inline]
    fn density(&self, ijk: IVec3) -> f32 {
        self.density.get(ijk)
    }
    fn density_range(&self, index_box: &IndexBox) -> (f32, f32) {
        index_box
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), ijk| {
                let v = self.density.get(ijk);
                (l.min(v), h.max(v))
            })
    }
    fn has_colour(&self) -> bool {
        self.colour.is_some()
    }
    fn colour(&self, ijk: IVec3) -> Rgb {
        self.colour.as_ref().map_or([0.0; 3], |c| c.get(ijk))
    }
}

impl VoxelSource for SparseVolume {
    fn grid(&self) -> &Grid {
        &self.grid
    }
    fn background(&self) -> f32 {
        self.density.background()
    }
    #[inline]
    fn density(&self, ijk: IVec3) -> f32 {
        if self.grid.contains(ijk) {
            self.density.get(ijk)
        } else {
            self.density.background()
        }
    }
    #[inline]
    fn density_cube(&self, base: IVec3) -> [f32; 8] {
        // Fast path: all eight corners inside the grid and inside one brick (about
        // two thirds of samples for 8³ bricks) cost one hash lookup instead of eight.
        let last = base + IVec3::ONE;
        let dims = self.grid.dims().as_ivec3();
        if base.cmpge(IVec3::ZERO).all() && last.cmplt(dims).all() && brick_of(base) == brick_of(last) {
            return match self.density.brick(brick_of(base)) {
                None => [self.density.background(); 8],
                Some(Brick::Uniform(v)) => [*v; 8],
                Some(Brick::Dense(d)) => {
                    let o = Brick::<f32>::local_offset(base);
                    let (sy, sz) = (BRICK_DIM as usize, (BRICK_DIM * BRICK_DIM) as usize);
                    [
                        d[o],
                        d[o + 1],
                        d[o + sy],
                        d[o + sy + 1],
                        d[o + sz],
                        d[o + sz + 1],
                        d[o + sz + sy],
                        d[o + sz + sy + 1],
                    ]
                }
            };
        }
        std::array::from_fn(|c| self.density(base + corner(c)))
    }
    fn density_range(&self, index_box: &IndexBox) -> (f32, f32) {
        self.density.range_in(index_box)
    }
    fn has_colour(&self) -> bool {
        self.colour.is_some()
    }
    fn colour(&self, ijk: IVec3) -> Rgb {
        match &self.colour {
            Some(c) if self.grid.contains(ijk) => c.get(ijk),
            _ => [0.0; 3],
        }
    }
}

/// A voxel source seen as a continuous [`Field`] through a reconstruction filter.
#[derive(Debug, Clone, Copy)]
pub struct Sampled<S> {
    source: S,
    filter: Filter,
}

impl<S: VoxelSource> Sampled<S> {
    pub fn new(source: S, filter: Filter) -> Self {
        Sampled { source, filter }
    }

    pub fn source(&self) -> &S {
        &self.source
    }

    pub fn filter(&self) -> Filter {
        self.filter
    }

    /// Trilinear weights' base voxel and fractions for a world point.
    #[inline]
    fn cell(&self, world_pos: DVec3) -> (IVec3, DVec3) {
        let index_pos = self.source.grid().transform.world_to_index(world_pos);
        let base = index_pos.floor();
        (clamp_to_ivec3(base), index_pos - base)
    }
}

impl<S: VoxelSource> Field for Sampled<S> {
    fn bounds(&self) -> Aabb {
        // Trilinear samples are background beyond one voxel outside the centres.
        self.source.grid().sampled_bounds()
    }

    fn background(&self) -> f64 {
        self.source.background() as f64
    }

    #[inline]
    fn value(&self, world_pos: DVec3) -> f64 {
        match self.filter {
            Filter::Nearest => {
                let ijk = self.source.grid().transform.nearest_voxel(world_pos);
                self.source.density(ijk) as f64
            }
            Filter::Trilinear => {
                let (base, f) = self.cell(world_pos);
                let c = self.source.density_cube(base).map(|v| v as f64);
                let x00 = c[0] + (c[1] - c[0]) * f.x;
                let x10 = c[2] + (c[3] - c[2]) * f.x;
                let x01 = c[4] + (c[5] - c[4]) * f.x;
                let x11 = c[6] + (c[7] - c[6]) * f.x;
                let y0 = x00 + (x10 - x00) * f.y;
                let y1 = x01 + (x11 - x01) * f.y;
                y0 + (y1 - y0) * f.z
            }
        }
    }

    fn gradient_step(&self) -> DVec3 {
        self.source.grid().transform.spacing()
    }

    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        let g = self.source.grid();
        let ib = g.index_box_touching(world_box);
        let bg = self.source.background();
        let (mut lo, mut hi) = if ib.is_empty() {
            (bg, bg)
        } else {
            self.source.density_range(&ib)
        };
        // Samples beyond the voxel centres blend in background voxels.
        let inner = g.center_bounds();
        if !(inner.contains(world_box.min) && inner.contains(world_box.max)) {
            lo = lo.min(bg);
            hi = hi.max(bg);
        }
        (lo as f64, hi as f64)
    }

    fn has_colour(&self) -> bool {
        self.source.has_colour()
    }

    /// Density-weighted trilinear colour, so empty (black) neighbours do not darken
    /// a surface; the nearest voxel's colour where all weights vanish.
    fn colour(&self, world_pos: DVec3) -> Option<Vec3> {
        if !self.source.has_colour() {
            return None;
        }
        let nearest = || {
            Vec3::from(
                self.source
                    .colour(self.source.grid().transform.nearest_voxel(world_pos)),
            )
        };
        if self.filter == Filter::Nearest {
            return Some(nearest());
        }
        let (base, f) = self.cell(world_pos);
        let d = self.source.density_cube(base);
        let mut sum = DVec3::ZERO;
        let mut wsum = 0.0;
        for (c, dc) in d.iter().enumerate() {
            let o = corner(c);
            let w = (if o.x == 1 { f.x } else { 1.0 - f.x })
                * (if o.y == 1 { f.y } else { 1.0 - f.y })
                * (if o.z == 1 { f.z } else { 1.0 - f.z })
                * (*dc as f64).max(0.0);
            if w > 0.0 {
                sum += Vec3::from(self.source.colour(base + o)).as_dvec3() * w;
                wsum += w;
            }
        }
        Some(if wsum > 0.0 { (sum / wsum).as_vec3() } else { nearest() })
    }
}

impl<S: VoxelSource + ?Sized> VoxelSource for &S {
    fn grid(&self) -> &Grid {
        (**self).grid()
    }
    fn background(&self) -> f32 {
        (**self).background()
    }
    fn density(&self, ijk: IVec3) -> f32 {
        (**self).density(ijk)
    }
    fn density_cube(&self, base: IVec3) -> [f32; 8] {
        (**self).density_cube(base)
    }
    fn density_range(&self, index_box: &IndexBox) -> (f32, f32) {
        (**self).density_range(index_box)
    }
    fn has_colour(&self) -> bool {
        (**self).has_colour()
    }
    fn colour(&self, ijk: IVec3) -> Rgb {
        (**self).colour(ijk)
    }
}
