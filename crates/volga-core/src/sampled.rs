use glam::{DVec3, IVec3, Vec3};

use crate::filters::{
    cubic_analytic_gradient, cubic_weights, separable_sum, trilinear_analytic_gradient, trilinear_central_gradient,
};
use crate::grid::{clamp_to_ivec3, fast_floor};
use crate::sparse::brick_of;
use crate::{
    Aabb, Brick, BrickAtlas, DenseVolume, Field, Filter, GradientMethod, Grid, IndexBox, Line, Rgb, SparseGrid,
    SparseVolume, BRICK_DIM, BRICK_SHAPE,
};

/// The voxels of a [`Sampled`] field and how it reconstructs them: what
/// [`Field::voxels`] returns.
pub struct SampledVoxels<'a> {
    /// The densities.
    pub source: Box<dyn VoxelBlock + 'a>,
    /// The reconstruction filter of values.
    pub filter: Filter,
    /// How gradients are computed.
    pub gradient: GradientMethod,
}

/// Read access to a grid of voxel densities by boxes, object safe (a [`VoxelSource`]
/// seen through [`Field::voxels`]).
pub trait VoxelBlock: Sync {
    /// The grid the densities live on.
    fn block_grid(&self) -> &Grid;
    /// The density outside the grid.
    fn block_background(&self) -> f32;
    /// `(min, max)` density over the voxels of `index_box`, already clipped to the grid
    /// (as [`VoxelSource::density_range`]).
    fn block_range(&self, index_box: &IndexBox) -> (f32, f32);
    /// The densities of the voxels of `index_box` (which may reach beyond the grid: the
    /// background there), x fastest, into `out`, whose length must be the box's volume
    /// (panics otherwise). The values equal [`VoxelSource::density`]'s bit for bit.
    fn read_block(&self, index_box: &IndexBox, out: &mut [f32]);
}

/// A [`VoxelSource`] as a [`VoxelBlock`].
struct SourceBlock<'a, S>(&'a S);

impl<S: VoxelSource> VoxelBlock for SourceBlock<'_, S> {
    fn block_grid(&self) -> &Grid {
        self.0.grid()
    }
    fn block_background(&self) -> f32 {
        self.0.background()
    }
    fn block_range(&self, index_box: &IndexBox) -> (f32, f32) {
        self.0.density_range(index_box)
    }
    fn read_block(&self, index_box: &IndexBox, out: &mut [f32]) {
        self.0.read_box(index_box, out);
    }
}

/// Voxel storage that [`Sampled`] can reconstruct from. Reads outside the grid
/// return the background value.
pub trait VoxelSource: Sync {
    /// The grid the voxels live on: their extent and world placement.
    fn grid(&self) -> &Grid;
    /// The density of every voxel outside the grid.
    fn background(&self) -> f32;
    /// Density of voxel `ijk`; the background outside the grid.
    fn density(&self, ijk: IVec3) -> f32;
    /// The 2×2×2 densities at `base + {0,1}³`, x fastest.
    fn density_cube(&self, base: IVec3) -> [f32; 8] {
        std::array::from_fn(|c| self.density(base + corner(c)))
    }
    /// `(min, max)` density over the voxels of `index_box`, already clipped to the grid.
    fn density_range(&self, index_box: &IndexBox) -> (f32, f32);
    /// The densities of every voxel of `index_box` (x fastest; the background outside the
    /// grid) into `out`, which must hold exactly the box: what [`VoxelSource::density`]
    /// gives voxel by voxel (the default), bricked sources by whole rows.
    fn read_box(&self, index_box: &IndexBox, out: &mut [f32]) {
        let size = (index_box.max - index_box.min).max(IVec3::ZERO);
        let (nx, ny) = (size.x as usize, size.y as usize);
        assert_eq!(
            out.len() as u64,
            index_box.volume(),
            "read_box: `out` must hold the box"
        );
        let mut reader = self.reader();
        for (o, d) in out.iter_mut().enumerate() {
            let local = IVec3::new((o % nx) as i32, ((o / nx) % ny) as i32, (o / (nx * ny)) as i32);
            *d = reader.density(index_box.min + local);
        }
    }
    /// Whether the source carries a colour channel.
    fn has_colour(&self) -> bool;
    /// Linear RGB of voxel `ijk`, each component in \[0, 1\]; black outside the grid and
    /// when the source has no colour channel.
    fn colour(&self, ijk: IVec3) -> Rgb;
    /// A reader for runs of nearby reads (the samples of one ray): it may cache what it
    /// looked up last, so it is made per run and dropped after.
    type Reader<'a>: VoxelReader
    where
        Self: 'a;
    /// A new [`VoxelSource::Reader`] for one run of reads (its cache starts empty).
    fn reader(&self) -> Self::Reader<'_>;
    /// What [`Field::prepare`] returns for a [`Sampled`] over this source with
    /// `filter` and `gradient`: the same reconstruction over a faster copy of the voxels (the same
    /// bits), or `None` (the default) to sample the source itself. Dense and sparse
    /// volumes return a [`Sampled`] over their [`BrickAtlas`](crate::BrickAtlas).
    fn prepared_field(&self, _filter: Filter, _gradient: GradientMethod) -> Option<Box<dyn Field + '_>> {
        None
    }
}

/// Reads densities like [`VoxelSource::density`] and [`VoxelSource::density_cube`]
/// (same values, background outside the grid), remembering what it looked up.
pub trait VoxelReader {
    /// Density of voxel `ijk`, equal to [`VoxelSource::density`]: the background outside
    /// the grid.
    fn density(&mut self, ijk: IVec3) -> f32;
    /// The 2×2×2 densities at `base + {0,1}³`, x fastest.
    #[inline]
    fn density_cube(&mut self, base: IVec3) -> [f32; 8] {
        std::array::from_fn(|c| self.density(base + corner(c)))
    }
    /// Writes the 4×4×4 densities at `base − 1 + {0,1,2,3}³` into `out` (x fastest:
    /// `out[x + 4y + 16z]`) and returns `true` if the reader can copy them from one
    /// contiguous block (a [`BrickAtlas`](crate::BrickAtlas) tile); returns `false`
    /// (the default) otherwise, and callers gather them from 2×2×2 cubes. Either way
    /// the values are the same.
    #[inline]
    fn density_block(&mut self, _base: IVec3, _out: &mut [f32; 64]) -> bool {
        false
    }
}

/// Reads a [`DenseVolume`] directly (nothing to cache).
pub struct DenseReader<'a>(&'a DenseVolume);

impl VoxelReader for DenseReader<'_> {
    #[inline]
    fn density(&mut self, ijk: IVec3) -> f32 {
        self.0.density.get(ijk)
    }
    #[inline]
    fn density_cube(&mut self, base: IVec3) -> [f32; 8] {
        let d = &self.0.density;
        let dims = d.shape().dims().as_ivec3();
        if base.cmpge(IVec3::ZERO).all() && (base + IVec3::ONE).cmplt(dims).all() {
            let o = d.shape().linearize(base);
            let (sy, sz) = (dims.x as usize, dims.x as usize * dims.y as usize);
            let v = d.as_slice();
            return [
                v[o],
                v[o + 1],
                v[o + sy],
                v[o + sy + 1],
                v[o + sz],
                v[o + sz + 1],
                v[o + sz + sy],
                v[o + sz + sy + 1],
            ];
        }
        std::array::from_fn(|c| d.get(base + corner(c)))
    }
}

/// Reads a [`SparseVolume`] through a cache of eight bricks, one slot per parity of
/// the brick coordinate (`(b.x & 1) | (b.y & 1) << 1 | (b.z & 1) << 2`): the bricks a
/// stencil of at most 8 voxels a side touches have distinct parities, so they all stay
/// cached, and a ray's samples cost one hash look-up per brick entered instead of one
/// per sample.
pub struct SparseReader<'a> {
    density: &'a SparseGrid<f32>,
    dims: IVec3,
    background: f32,
    keys: [IVec3; 8],
    /// [`SparseGrid::brick_voxels`] of the brick in each slot: 512 values or one.
    slices: [&'a [f32]; 8],
}

impl<'a> SparseReader<'a> {
    fn new(volume: &'a SparseVolume) -> Self {
        SparseReader {
            density: &volume.density,
            dims: volume.grid.dims().as_ivec3(),
            background: volume.density.background(),
            // No brick has this coordinate (grids are at most i32::MAX / 2 voxels a side).
            keys: [IVec3::splat(i32::MIN); 8],
            slices: [&[]; 8],
        }
    }

    #[inline(always)]
    fn brick(&mut self, brick: IVec3) -> &'a [f32] {
        let slot = ((brick.x & 1) | ((brick.y & 1) << 1) | ((brick.z & 1) << 2)) as usize;
        if self.keys[slot] != brick {
            self.keys[slot] = brick;
            self.slices[slot] = self.density.brick_voxels(brick);
        }
        self.slices[slot]
    }
}

impl VoxelReader for SparseReader<'_> {
    #[inline]
    fn density(&mut self, ijk: IVec3) -> f32 {
        if ijk.cmplt(IVec3::ZERO).any() || ijk.cmpge(self.dims).any() {
            return self.background;
        }
        let voxels = self.brick(brick_of(ijk));
        voxels[Brick::<f32>::local_offset(ijk) & (voxels.len() - 1)]
    }

    #[inline]
    fn density_cube(&mut self, base: IVec3) -> [f32; 8] {
        let local = base & IVec3::splat(BRICK_DIM - 1);
        let inside = base.cmpge(IVec3::ZERO).all() && (base + IVec3::ONE).cmplt(self.dims).all();
        if !inside {
            return std::array::from_fn(|c| self.density(base + corner(c)));
        }
        if local.cmplt(IVec3::splat(BRICK_DIM - 1)).all() {
            // All eight corners in one brick.
            let voxels = self.brick(brick_of(base));
            if voxels.len() == 1 {
                return [voxels[0]; 8];
            }
            let o = BRICK_SHAPE.linearize(local);
            let (sy, sz) = (BRICK_DIM as usize, (BRICK_DIM * BRICK_DIM) as usize);
            return [
                voxels[o],
                voxels[o + 1],
                voxels[o + sy],
                voxels[o + sy + 1],
                voxels[o + sz],
                voxels[o + sz + 1],
                voxels[o + sz + sy],
                voxels[o + sz + sy + 1],
            ];
        }
        // Across a brick seam, inside the grid: each corner from its cached brick.
        std::array::from_fn(|c| {
            let ijk = base + corner(c);
            let voxels = self.brick(brick_of(ijk));
            voxels[Brick::<f32>::local_offset(ijk) & (voxels.len() - 1)]
        })
    }
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
    type Reader<'a> = DenseReader<'a>;
    fn reader(&self) -> DenseReader<'_> {
        DenseReader(self)
    }
    fn prepared_field(&self, filter: Filter, gradient: GradientMethod) -> Option<Box<dyn Field + '_>> {
        let atlas = BrickAtlas::build(self)?;
        Some(Box::new(Sampled::new(atlas, filter).with_gradient(gradient)))
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
    /// Brick by brick: each brick's part of the box copied (or filled) row by row.
    fn read_box(&self, index_box: &IndexBox, out: &mut [f32]) {
        let size = (index_box.max - index_box.min).max(IVec3::ZERO);
        assert_eq!(
            out.len() as u64,
            index_box.volume(),
            "read_box: `out` must hold the box"
        );
        out.fill(self.density.background());
        let inner = index_box.intersection(&self.grid.index_box());
        if inner.is_empty() {
            return;
        }
        let (nx, ny) = (size.x as usize, size.y as usize);
        let (b_lo, b_hi) = (brick_of(inner.min), brick_of(inner.max - IVec3::ONE));
        for bz in b_lo.z..=b_hi.z {
            for by in b_lo.y..=b_hi.y {
                for bx in b_lo.x..=b_hi.x {
                    let brick = IVec3::new(bx, by, bz);
                    let voxels = self.density.brick_voxels(brick);
                    let lo = inner.min.max(brick * BRICK_DIM);
                    let hi = inner.max.min((brick + IVec3::ONE) * BRICK_DIM);
                    let len = (hi.x - lo.x) as usize;
                    for z in lo.z..hi.z {
                        for y in lo.y..hi.y {
                            let rel = IVec3::new(lo.x, y, z) - index_box.min;
                            let dst = rel.x as usize + nx * (rel.y as usize + ny * rel.z as usize);
                            let row = &mut out[dst..dst + len];
                            if voxels.len() == 1 {
                                row.fill(voxels[0]);
                            } else {
                                let src = Brick::<f32>::local_offset(IVec3::new(lo.x, y, z));
                                row.copy_from_slice(&voxels[src..src + len]);
                            }
                        }
                    }
                }
            }
        }
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
    type Reader<'a> = SparseReader<'a>;
    fn reader(&self) -> SparseReader<'_> {
        SparseReader::new(self)
    }
    fn prepared_field(&self, filter: Filter, gradient: GradientMethod) -> Option<Box<dyn Field + '_>> {
        let atlas = BrickAtlas::build(self)?;
        Some(Box::new(Sampled::new(atlas, filter).with_gradient(gradient)))
    }
}

/// A voxel source seen as a continuous [`Field`] through a reconstruction filter
/// ([`Filter`]), with gradients by the chosen [`GradientMethod`] (default: central
/// differences of the reconstruction).
#[derive(Debug, Clone, Copy)]
pub struct Sampled<S> {
    source: S,
    filter: Filter,
    gradient: GradientMethod,
}

impl<S: VoxelSource> Sampled<S> {
    /// Reconstructs `source` with `filter`; gradients by central differences (the default
    /// [`GradientMethod`]; see [`Sampled::with_gradient`]).
    pub fn new(source: S, filter: Filter) -> Self {
        Sampled {
            source,
            filter,
            gradient: GradientMethod::default(),
        }
    }

    /// The same field with gradients taken by `method`.
    pub fn with_gradient(mut self, method: GradientMethod) -> Self {
        self.gradient = method;
        self
    }

    /// The voxels being reconstructed.
    pub fn source(&self) -> &S {
        &self.source
    }

    /// The reconstruction filter of values.
    pub fn filter(&self) -> Filter {
        self.filter
    }

    /// How [`Field::gradient`] is computed.
    pub fn gradient_method(&self) -> GradientMethod {
        self.gradient
    }

    /// The 4×4×4 voxels `base − 1 ..= base + 2` (x fastest): one copy from the reader's
    /// block if it has one, else gathered from the eight 2×2×2 cubes at
    /// `base − 1 + {0, 2}³` (which read across brick seams and the grid's faces).
    #[inline(always)]
    fn block<R: VoxelReader>(reader: &mut R, base: IVec3) -> [f32; 64] {
        let mut block = [0.0f32; 64];
        if !reader.density_block(base, &mut block) {
            for c in 0..8 {
                let o = corner(c) * 2;
                let cube = reader.density_cube(base - IVec3::ONE + o);
                for (k, v) in cube.iter().enumerate() {
                    let q = o + corner(k);
                    block[q.x as usize + 4 * q.y as usize + 16 * q.z as usize] = *v;
                }
            }
        }
        block
    }

    /// The reconstruction at continuous index coordinates `index_pos`, read through
    /// `reader` (the same formula as [`Field::value`] after its `world_to_index`).
    #[inline]
    fn value_at_index<R: VoxelReader>(&self, reader: &mut R, index_pos: DVec3) -> f64 {
        match self.filter {
            Filter::Nearest => reader.density(clamp_to_ivec3(floor(index_pos + 0.5))) as f64,
            Filter::Trilinear => {
                let base = floor(index_pos);
                trilerp(reader.density_cube(clamp_to_ivec3(base)), index_pos - base)
            }
            Filter::CatmullRom | Filter::BSpline => {
                let base_pos = floor(index_pos);
                let f = index_pos - base_pos;
                let block = Self::block(reader, clamp_to_ivec3(base_pos));
                let w = |t: f64| cubic_weights(self.filter, t);
                separable_sum(&block, &w(f.x), &w(f.y), &w(f.z))
            }
        }
    }

    /// The world-space gradient at continuous index coordinates `index_pos` by the
    /// field's [`GradientMethod`]. Central differences are taken one voxel apart along
    /// each index axis and divided by the world distance; for trilinear reconstruction
    /// the six neighbours share the point's cell fractions, so one 4×4×4 block serves
    /// all of them.
    #[inline]
    fn gradient_at_index<R: VoxelReader>(&self, reader: &mut R, index_pos: DVec3) -> DVec3 {
        let spacing = self.source.grid().transform.spacing();
        let cell = |reader: &mut R| {
            let base_pos = floor(index_pos);
            (Self::block(reader, clamp_to_ivec3(base_pos)), index_pos - base_pos)
        };
        match (self.filter, self.gradient) {
            (Filter::Trilinear, GradientMethod::CentralDifference) => {
                let (block, f) = cell(reader);
                trilinear_central_gradient(&block, f, spacing)
            }
            (Filter::Trilinear, GradientMethod::Analytic) => {
                let (block, f) = cell(reader);
                trilinear_analytic_gradient(&block, f, spacing)
            }
            (Filter::CatmullRom | Filter::BSpline, GradientMethod::Analytic) => {
                let (block, f) = cell(reader);
                cubic_analytic_gradient(self.filter, &block, f, spacing)
            }
            // A piecewise-constant reconstruction has zero derivative inside its cells.
            (Filter::Nearest, GradientMethod::Analytic) => DVec3::ZERO,
            (Filter::Nearest | Filter::CatmullRom | Filter::BSpline, GradientMethod::CentralDifference) => {
                let mut g = DVec3::ZERO;
                for a in 0..3 {
                    let mut e = DVec3::ZERO;
                    e[a] = 1.0;
                    let forward = self.value_at_index(reader, index_pos + e);
                    let backward = self.value_at_index(reader, index_pos - e);
                    g[a] = (forward - backward) / (2.0 * spacing[a]);
                }
                g
            }
        }
    }

    /// Trilinear weights' base voxel and fractions for a world point.
    #[inline]
    fn cell(&self, world_pos: DVec3) -> (IVec3, DVec3) {
        let index_pos = self.source.grid().transform.world_to_index(world_pos);
        let base = floor(index_pos);
        (clamp_to_ivec3(base), index_pos - base)
    }
}

/// [`fast_floor`] on each axis.
#[inline]
fn floor(v: DVec3) -> DVec3 {
    v.map(fast_floor)
}

/// Trilinear interpolation of the 2×2×2 corner values `c` (x fastest) at fractions `f`.
#[inline]
fn trilerp(c: [f32; 8], f: DVec3) -> f64 {
    let c = c.map(|v| v as f64);
    let x00 = c[0] + (c[1] - c[0]) * f.x;
    let x10 = c[2] + (c[3] - c[2]) * f.x;
    let x01 = c[4] + (c[5] - c[4]) * f.x;
    let x11 = c[6] + (c[7] - c[6]) * f.x;
    let y0 = x00 + (x10 - x00) * f.y;
    let y1 = x01 + (x11 - x01) * f.y;
    y0 + (y1 - y0) * f.z
}

impl<S: VoxelSource> Field for Sampled<S> {
    fn bounds(&self) -> Aabb {
        // Samples are background beyond the filter's reach outside the centres (one
        // voxel for nearest and trilinear, two for the cubics).
        let g = self.source.grid();
        g.center_bounds()
            .expanded(g.transform.spacing() * self.filter.reach_voxels())
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
                trilerp(self.source.density_cube(base), f)
            }
            Filter::CatmullRom | Filter::BSpline => {
                let index_pos = self.source.grid().transform.world_to_index(world_pos);
                self.value_at_index(&mut self.source.reader(), index_pos)
            }
        }
    }

    /// Walks the line in index space (`index_pos(i) = index_origin + i·index_step`, a
    /// function of `i` alone) through one [`VoxelReader`], so consecutive samples in a
    /// brick share its look-up.
    fn values_along(&self, line: &Line, first: u64, out: &mut [f64]) {
        let transform = &self.source.grid().transform;
        let index_origin = transform.world_to_index(line.origin);
        let index_step = line.step / transform.spacing();
        let mut reader = self.source.reader();
        for (k, v) in out.iter_mut().enumerate() {
            let index_pos = index_origin + index_step * (first + k as u64) as f64;
            *v = self.value_at_index(&mut reader, index_pos);
        }
    }

    /// The gradient by the field's [`GradientMethod`], taken in index space (so the
    /// samples share the fractions of the point and a brick look-up).
    fn gradient(&self, world_pos: DVec3) -> DVec3 {
        let index_pos = self.source.grid().transform.world_to_index(world_pos);
        self.gradient_at_index(&mut self.source.reader(), index_pos)
    }

    /// [`Field::gradient`] at each point through one [`VoxelReader`].
    fn gradients_at(&self, world_pos: &[DVec3], out: &mut [DVec3]) {
        let transform = &self.source.grid().transform;
        let mut reader = self.source.reader();
        for (g, p) in out.iter_mut().zip(world_pos) {
            *g = self.gradient_at_index(&mut reader, transform.world_to_index(*p));
        }
    }

    fn gradient_step(&self) -> DVec3 {
        self.source.grid().transform.spacing()
    }

    /// The same reconstruction over a [`BrickAtlas`] of the source (bit-identical
    /// densities, so bit-identical values and gradients); `None` if the source is one
    /// already or the atlas would exceed [`MAX_ATLAS_BYTES`](crate::MAX_ATLAS_BYTES).
    fn prepare(&self) -> Option<Box<dyn Field + '_>> {
        self.source.prepared_field(self.filter, self.gradient)
    }

    /// The source's voxels with this field's filter and gradient method.
    fn voxels(&self) -> Option<SampledVoxels<'_>> {
        Some(SampledVoxels {
            source: Box::new(SourceBlock(&self.source)),
            filter: self.filter,
            gradient: self.gradient,
        })
    }

    /// The voxels' range over the box grown by the filter's reach (and the background
    /// where samples blend it in), widened by the filter's
    /// [`overshoot`](Filter::overshoot) around its midpoint.
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        let g = self.source.grid();
        let spacing = g.transform.spacing();
        // Cubic samples read one voxel further on each side than trilinear ones.
        let extra = spacing * (self.filter.reach_voxels() - 1.0);
        let ib = g.index_box_touching(&world_box.expanded(extra));
        let bg = self.source.background();
        let (mut lo, mut hi) = if ib.is_empty() {
            (bg, bg)
        } else {
            self.source.density_range(&ib)
        };
        // Samples beyond the voxel centres (for cubics: within one voxel of them)
        // blend in background voxels.
        let inner = g.center_bounds();
        let inner = Aabb::new(inner.min + extra, inner.max - extra);
        if !(inner.contains(world_box.min) && inner.contains(world_box.max)) {
            lo = lo.min(bg);
            hi = hi.max(bg);
        }
        let (lo, hi) = (lo as f64, hi as f64);
        if !self.filter.is_cubic() {
            return (lo, hi);
        }
        // The cubics' 64 products and sums round: pad by far more than their error.
        let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo) * self.filter.overshoot());
        let pad = 1e-12 * (lo.abs() + hi.abs()) + f64::MIN_POSITIVE;
        (mid - half - pad, mid + half + pad)
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
        // Every other filter colours by density-weighted trilinear weights.
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
    fn read_box(&self, index_box: &IndexBox, out: &mut [f32]) {
        (**self).read_box(index_box, out)
    }
    fn has_colour(&self) -> bool {
        (**self).has_colour()
    }
    fn colour(&self, ijk: IVec3) -> Rgb {
        (**self).colour(ijk)
    }
    type Reader<'a>
        = S::Reader<'a>
    where
        Self: 'a;
    fn reader(&self) -> S::Reader<'_> {
        (**self).reader()
    }
    fn prepared_field(&self, filter: Filter, gradient: GradientMethod) -> Option<Box<dyn Field + '_>> {
        (**self).prepared_field(filter, gradient)
    }
}
