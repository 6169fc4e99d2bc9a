use std::sync::Arc;

use glam::{IVec3, UVec3};
use rayon::prelude::*;
use rustc_hash::FxHashMap;

use crate::{ChannelKind, CoreError, DenseVolume, Grid, IndexBox, Rgb, Shape3};

/// log2 of the brick edge length.
pub const BRICK_LOG2: i32 = 3;
/// Brick edge length in voxels (8).
pub const BRICK_DIM: i32 = 1 << BRICK_LOG2;
/// Voxels per brick (512).
pub const BRICK_VOXELS: usize = (BRICK_DIM * BRICK_DIM * BRICK_DIM) as usize;
/// Layout of the voxels inside a brick (8³, x fastest).
pub const BRICK_SHAPE: Shape3 = Shape3::new_unchecked(UVec3::splat(BRICK_DIM as u32));

/// One 8³ block of voxels: either one value for all 512 voxels, or each stored.
///
/// Dense voxels are shared copy-on-write: cloning a brick (or a whole [`SparseGrid`])
/// copies a pointer, and the first write through [`SparseGrid::set`] or
/// [`SparseGrid::brick_data_mut`] copies the 512 values only if another version still
/// holds them (`Arc::make_mut`). An undo stack can therefore keep whole versions of a
/// volume and pay only for the bricks that changed ([`SparseGrid::changed_bricks`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Brick<T> {
    /// All 512 voxels have this value (nothing allocated).
    Uniform(T),
    /// Each voxel stored, x fastest ([`Brick::local_offset`]); shared copy-on-write
    /// between clones.
    Dense(Arc<[T; BRICK_VOXELS]>),
}

impl<T: Copy + PartialEq> Brick<T> {
    /// Offset of a voxel inside its brick from its `ijk` (x fastest: the
    /// [`BRICK_SHAPE`] layout of the voxel's position in its brick).
    #[inline]
    pub fn local_offset(ijk: IVec3) -> usize {
        BRICK_SHAPE.linearize(ijk & IVec3::splat(BRICK_DIM - 1))
    }

    /// Value of the voxel at `offset` in the brick (from [`Brick::local_offset`], below
    /// 512). Panics if `offset ≥ 512` on a dense brick; a uniform brick ignores `offset`.
    #[inline]
    pub fn get_local(&self, offset: usize) -> T {
        match self {
            Brick::Uniform(v) => *v,
            Brick::Dense(d) => d[offset],
        }
    }

    /// The collapsed brick holding `voxels` (x fastest): uniform, without allocating,
    /// if all are equal, else dense (one allocation, not shared).
    #[inline]
    pub fn from_voxels(voxels: &[T; BRICK_VOXELS]) -> Self {
        let first = voxels[0];
        if voxels.iter().all(|v| *v == first) {
            Brick::Uniform(first)
        } else {
            Brick::Dense(Arc::new(*voxels))
        }
    }

    /// A uniform brick if every value is equal, else the dense brick unchanged.
    pub fn collapsed(self) -> Self {
        match self {
            Brick::Dense(d) if d.iter().all(|v| *v == d[0]) => Brick::Uniform(d[0]),
            b => b,
        }
    }

    /// The voxels for writing: a uniform brick becomes dense, and dense voxels shared
    /// with another version are copied first (copy-on-write).
    fn densify(&mut self) -> &mut [T; BRICK_VOXELS] {
        match self {
            Brick::Dense(d) => Arc::make_mut(d),
            Brick::Uniform(v) => {
                *self = Brick::Dense(Arc::new([*v; BRICK_VOXELS]));
                self.densify()
            }
        }
    }

    /// Whether `self` and `other` are the same version of a brick without comparing
    /// voxels: equal uniform values, or dense voxels at the same address (shared by a
    /// clone and not written since). Two dense bricks with equal values written
    /// separately are *not* the same version.
    #[inline]
    pub fn same_version(&self, other: &Brick<T>) -> bool {
        match (self, other) {
            (Brick::Uniform(a), Brick::Uniform(b)) => a == b,
            (Brick::Dense(a), Brick::Dense(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }

    /// Whether the dense voxels of this brick are shared with another version.
    pub fn is_shared(&self) -> bool {
        matches!(self, Brick::Dense(d) if Arc::strong_count(d) > 1)
    }
}

/// Brick coordinate (**brick space**) of voxel `ijk`: `ijk >> 3`, arithmetic shift so
/// negative voxels map to negative bricks.
#[inline]
pub fn brick_of(ijk: IVec3) -> IVec3 {
    ijk >> BRICK_LOG2
}

/// Sparse bricked storage: 8³ bricks in a hash map keyed by brick coordinate; voxels
/// in absent bricks read as `background`.
///
/// Iteration order of the map never reaches results: everything that walks bricks in
/// an order that matters uses [`SparseGrid::sorted_bricks`].
#[derive(Debug, Clone)]
pub struct SparseGrid<T> {
    bricks: FxHashMap<IVec3, Brick<T>>,
    background: T,
}

impl<T: Copy + PartialEq + Send + Sync> SparseGrid<T> {
    /// An empty grid: no brick stored, every voxel reads `background`.
    pub fn new(background: T) -> Self {
        SparseGrid {
            bricks: FxHashMap::default(),
            background,
        }
    }

    /// The value of every voxel in an absent brick.
    pub fn background(&self) -> T {
        self.background
    }

    /// Value of voxel `ijk`, the background in an absent brick. The grid has no extent:
    /// any `ijk`, negative ones included, is valid.
    #[inline]
    pub fn get(&self, ijk: IVec3) -> T {
        match self.bricks.get(&brick_of(ijk)) {
            Some(b) => b.get_local(Brick::<T>::local_offset(ijk)),
            None => self.background,
        }
    }

    /// Writes `value` at voxel `ijk` (any coordinates). The brick is created if absent
    /// (as uniform background), made dense unless `value` equals its uniform value, and
    /// copied first if its voxels are shared with another version. A write never removes
    /// or collapses a brick (even writing the background into an absent one stores it):
    /// see [`SparseGrid::prune`].
    pub fn set(&mut self, ijk: IVec3, value: T) {
        let bg = self.background;
        let brick = self.bricks.entry(brick_of(ijk)).or_insert(Brick::Uniform(bg));
        if let Brick::Uniform(v) = brick {
            if *v == value {
                return;
            }
        }
        brick.densify()[Brick::<T>::local_offset(ijk)] = value;
    }

    /// The brick at brick coordinate `brick`, or `None` if absent (all background).
    pub fn brick(&self, brick: IVec3) -> Option<&Brick<T>> {
        self.bricks.get(&brick)
    }

    /// The voxels of brick `brick` as a slice, for readers that cache bricks: the 512
    /// voxels of a dense brick (x fastest, see [`Brick::local_offset`]), or **one**
    /// value for a uniform brick or an absent one (the background). Voxel `offset` of
    /// the brick is `slice[offset & (slice.len() - 1)]` either way.
    #[inline]
    pub fn brick_voxels(&self, brick: IVec3) -> &[T] {
        match self.bricks.get(&brick) {
            None => std::slice::from_ref(&self.background),
            Some(Brick::Uniform(v)) => std::slice::from_ref(v),
            Some(Brick::Dense(d)) => &d[..],
        }
    }

    /// The 512 voxels of brick `brick` for writing (x fastest, see
    /// [`Brick::local_offset`]): an absent brick is created as background, a uniform one
    /// made dense, and voxels shared with another version copied first.
    pub fn brick_data_mut(&mut self, brick: IVec3) -> &mut [T; BRICK_VOXELS] {
        let bg = self.background;
        self.bricks.entry(brick).or_insert(Brick::Uniform(bg)).densify()
    }

    /// Bricks that may differ between `self` and `other` (two versions of one grid, e.g.
    /// an edit and its undo copy), in (z, y, x) order, found by pointer equality without
    /// reading voxels: present in one only, different uniform values, or dense voxels not
    /// shared. Conservative: a brick rewritten with its old values is listed. Returns
    /// every brick of both if the backgrounds differ.
    pub fn changed_bricks(&self, other: &SparseGrid<T>) -> Vec<IVec3> {
        let mut out: Vec<IVec3> = if self.background != other.background {
            self.bricks.keys().chain(other.bricks.keys()).copied().collect()
        } else {
            let ours = self.bricks.iter().filter(|(b, brick)| match other.bricks.get(b) {
                Some(theirs) => !brick.same_version(theirs),
                None => true,
            });
            let theirs_only = other.bricks.keys().filter(|b| !self.bricks.contains_key(b));
            ours.map(|(b, _)| *b).chain(theirs_only.copied()).collect()
        };
        out.sort_unstable_by_key(|b| (b.z, b.y, b.x));
        out.dedup();
        out
    }

    /// Puts `data` at brick coordinate `brick`, replacing what was there.
    pub fn insert_brick(&mut self, brick: IVec3, data: Brick<T>) {
        self.bricks.insert(brick, data);
    }

    /// Removes the brick at brick coordinate `brick`, so its voxels read as background,
    /// and returns it; `None` if it was absent.
    pub fn remove_brick(&mut self, brick: IVec3) -> Option<Brick<T>> {
        self.bricks.remove(&brick)
    }

    /// Brick coordinates in lexicographic (z, y, x) order.
    pub fn sorted_bricks(&self) -> Vec<IVec3> {
        let mut v: Vec<IVec3> = self.bricks.keys().copied().collect();
        v.sort_unstable_by_key(|b| (b.z, b.y, b.x));
        v
    }

    /// Collapses bricks whose voxels are all equal and drops those equal to the
    /// background, so storage follows the content, not the history of edits.
    pub fn prune(&mut self) {
        let bg = self.background;
        self.bricks.par_iter_mut().for_each(|(_, b)| {
            let owned = std::mem::replace(b, Brick::Uniform(bg));
            *b = owned.collapsed();
        });
        self.bricks.retain(|_, b| *b != Brick::Uniform(bg));
    }

    /// Number of stored bricks, uniform and dense.
    pub fn brick_count(&self) -> usize {
        self.bricks.len()
    }

    /// Number of stored bricks that hold 512 values ([`Brick::Dense`]).
    pub fn dense_brick_count(&self) -> usize {
        self.bricks.values().filter(|b| matches!(b, Brick::Dense(_))).count()
    }

    /// Bytes held by bricks and the map (an estimate of the map's own overhead). Dense
    /// voxels shared with other versions are counted in full in each.
    pub fn memory_bytes(&self) -> u64 {
        let per_entry = (std::mem::size_of::<(IVec3, Brick<T>)>() + 1) as u64;
        let dense = self.dense_brick_count() as u64 * (BRICK_VOXELS * std::mem::size_of::<T>()) as u64;
        self.bricks.capacity() as u64 * per_entry + dense
    }

    /// Number of voxels inside `index_box` whose value differs from the background.
    pub fn count_active_in(&self, index_box: &IndexBox) -> u64 {
        let bg = self.background;
        self.sorted_bricks()
            .par_iter()
            .map(|&b| {
                let bbox = brick_index_box(b).intersection(index_box);
                match &self.bricks[&b] {
                    Brick::Uniform(v) if *v == bg => 0,
                    Brick::Uniform(_) => bbox.volume(),
                    Brick::Dense(d) => bbox
                        .iter()
                        .filter(|&ijk| d[Brick::<T>::local_offset(ijk)] != bg)
                        .count() as u64,
                }
            })
            .sum()
    }
}

impl SparseGrid<f32> {
    /// Minimum and maximum over the voxels of `index_box` (background for absent bricks).
    pub fn range_in(&self, index_box: &IndexBox) -> (f32, f32) {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        if index_box.is_empty() {
            return (self.background, self.background);
        }
        let b0 = brick_of(index_box.min);
        let b1 = brick_of(index_box.max - IVec3::ONE);
        for bz in b0.z..=b1.z {
            for by in b0.y..=b1.y {
                for bx in b0.x..=b1.x {
                    let b = IVec3::new(bx, by, bz);
                    let (l, h) = match self.bricks.get(&b) {
                        None => (self.background, self.background),
                        Some(Brick::Uniform(v)) => (*v, *v),
                        Some(Brick::Dense(d)) => {
                            let sub = brick_index_box(b).intersection(index_box);
                            sub.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), ijk| {
                                let v = d[Brick::<f32>::local_offset(ijk)];
                                (l.min(v), h.max(v))
                            })
                        }
                    };
                    lo = lo.min(l);
                    hi = hi.max(h);
                }
            }
        }
        (lo, hi)
    }
}

/// The voxels of brick `brick` in index space.
pub fn brick_index_box(brick: IVec3) -> IndexBox {
    let min = brick * BRICK_DIM;
    IndexBox::new(min, min + IVec3::splat(BRICK_DIM))
}

/// The main volume storage: a grid with a sparse scalar channel and an optional
/// sparse colour channel (allocated only when something reads it).
///
/// The scalar channel is called `density` for history; what it holds is
/// [`SparseVolume::density_kind`] (density, signed distance or binary occupancy), set
/// by whoever fills it. Cloning a volume is cheap: dense bricks are shared
/// copy-on-write (see [`Brick`]).
#[derive(Debug, Clone)]
pub struct SparseVolume {
    /// Extent and world placement. The channels may hold bricks beyond it, but sampling
    /// ([`VoxelSource`](crate::VoxelSource)), [`SparseVolume::to_dense`] and
    /// [`SparseVolume::active_voxel_count`] treat voxels outside `0 ≤ ijk < dims` as
    /// background.
    pub grid: Grid,
    /// The scalar channel (what it holds: `density_kind`), indexed by voxel `ijk`.
    pub density: SparseGrid<f32>,
    /// Linear RGB per voxel, each component in \[0, 1\]; present only for a volume made
    /// `with_colour`, black in absent bricks.
    pub colour: Option<SparseGrid<Rgb>>,
    /// What the `density` channel holds (never [`ChannelKind::Colour`] from volga's
    /// producers). [`SparseVolume::new`] sets [`ChannelKind::Density`].
    pub density_kind: ChannelKind,
}

impl SparseVolume {
    /// An empty volume whose scalar channel holds densities.
    pub fn new(grid: Grid, background: f32, with_colour: bool) -> Self {
        SparseVolume {
            grid,
            density: SparseGrid::new(background),
            colour: with_colour.then(|| SparseGrid::new([0.0; 3])),
            density_kind: ChannelKind::Density,
        }
    }

    /// The same volume with its scalar channel declared to hold `kind`.
    pub fn with_density_kind(mut self, kind: ChannelKind) -> Self {
        self.density_kind = kind;
        self
    }

    /// Each channel present with what it holds: `("density", kind)` and, when the
    /// colour channel exists, `("colour", ChannelKind::Colour)`.
    pub fn channels(&self) -> Vec<(&'static str, ChannelKind)> {
        let mut out = vec![("density", self.density_kind)];
        if self.colour.is_some() {
            out.push(("colour", ChannelKind::Colour));
        }
        out
    }

    /// Bricks of either channel that may differ from `earlier` (another version of this
    /// volume), by pointer equality; see [`SparseGrid::changed_bricks`].
    pub fn changed_bricks(&self, earlier: &SparseVolume) -> Vec<IVec3> {
        let mut out = self.density.changed_bricks(&earlier.density);
        match (&self.colour, &earlier.colour) {
            (Some(a), Some(b)) => out.extend(a.changed_bricks(b)),
            (Some(c), None) | (None, Some(c)) => out.extend(c.sorted_bricks()),
            (None, None) => {}
        }
        out.sort_unstable_by_key(|b| (b.z, b.y, b.x));
        out.dedup();
        out
    }

    /// Brick coordinates covering the grid: `0 ≤ brick < ceil(dims / 8)`.
    pub fn brick_extent(&self) -> IVec3 {
        brick_extent(self.grid.dims())
    }

    /// Voxels inside the grid whose density differs from the background.
    pub fn active_voxel_count(&self) -> u64 {
        self.density.count_active_in(&self.grid.index_box())
    }

    /// Bytes held by both channels: the sum of their [`SparseGrid::memory_bytes`].
    pub fn memory_bytes(&self) -> u64 {
        self.density.memory_bytes() + self.colour.as_ref().map_or(0, |c| c.memory_bytes())
    }

    /// A volume on the same grid whose scalar channel is `f` of this one's, voxel by
    /// voxel (the background too), brick by brick: a uniform brick stays one value, a
    /// dense brick collapses if `f` makes it uniform, bricks equal to the new background
    /// are dropped. No colour; the channel keeps `density_kind` (set another with
    /// [`SparseVolume::with_density_kind`]).
    pub fn map_density(&self, f: impl Fn(f32) -> f32 + Sync) -> SparseVolume {
        let background = f(self.density.background());
        let bricks = self.density.sorted_bricks();
        let mapped: Vec<(IVec3, Brick<f32>)> = bricks
            .par_iter()
            .filter_map(|&b| {
                let brick = match self.density.brick(b)? {
                    Brick::Uniform(v) => Brick::Uniform(f(*v)),
                    Brick::Dense(d) => Brick::from_voxels(&d.map(&f)),
                };
                (brick != Brick::Uniform(background)).then_some((b, brick))
            })
            .collect();
        let mut out = SparseVolume::new(self.grid, background, false).with_density_kind(self.density_kind);
        for (b, brick) in mapped {
            out.density.insert_brick(b, brick);
        }
        out
    }

    /// The voxels of `region` (index space) as a volume of their own, on
    /// [`Grid::window`]: voxel `ijk` of the result is voxel `region.min + ijk` of this
    /// one, bit for bit, in both channels. Bricks are shared (copy-on-write) when
    /// `region.min` is a multiple of the brick size, except those cut by `region.max`;
    /// otherwise copied voxel by voxel. Errors like [`Grid::window`].
    pub fn window(&self, region: &IndexBox) -> Result<SparseVolume, CoreError> {
        let grid = self.grid.window(region)?;
        let mut out = SparseVolume::new(grid, self.density.background(), self.colour.is_some())
            .with_density_kind(self.density_kind);
        out.density = window_channel(&self.density, region);
        if let (Some(dst), Some(src)) = (out.colour.as_mut(), self.colour.as_ref()) {
            *dst = window_channel(src, region);
        }
        Ok(out)
    }

    /// Densifies the volume; fails if the grid is too large to address.
    pub fn to_dense(&self) -> Result<DenseVolume, CoreError> {
        let mut out = DenseVolume::new(self.grid, self.density.background(), self.colour.is_some())?;
        let shape = out.density.shape();
        let dims = shape.dims().as_ivec3();
        let plane = shape.plane_len();
        out.density
            .as_mut_slice()
            .par_chunks_mut(plane)
            .enumerate()
            .for_each(|(z, slab)| {
                let z = z as i32;
                for (ijk, v) in IndexBox::new(IVec3::new(0, 0, z), IVec3::new(dims.x, dims.y, z + 1))
                    .iter()
                    .zip(slab.iter_mut())
                {
                    *v = self.density.get(ijk);
                }
            });
        if let (Some(dst), Some(src)) = (out.colour.as_mut(), self.colour.as_ref()) {
            for (i, c) in dst.as_mut_slice().iter_mut().enumerate() {
                *c = src.get(shape.delinearize(i));
            }
        }
        Ok(out)
    }

    /// Stores a dense volume brick by brick, collapsing uniform bricks.
    pub fn from_dense(dense: &DenseVolume) -> SparseVolume {
        let mut out = SparseVolume::new(dense.grid, dense.density.background(), dense.colour.is_some());
        let ext = brick_extent(dense.grid.dims());
        let coords: Vec<IVec3> = IndexBox::new(IVec3::ZERO, ext).iter().collect();
        let density: Vec<_> = coords
            .par_iter()
            .map(|&b| (b, gather_brick(b, |ijk| dense.density.get(ijk))))
            .collect();
        for (b, brick) in density {
            if brick != Brick::Uniform(out.density.background()) {
                out.density.insert_brick(b, brick);
            }
        }
        if let (Some(dst), Some(src)) = (out.colour.as_mut(), dense.colour.as_ref()) {
            for &b in &coords {
                let brick = gather_brick(b, |ijk| src.get(ijk));
                if brick != Brick::Uniform(dst.background()) {
                    dst.insert_brick(b, brick);
                }
            }
        }
        out
    }
}

/// The bricks of `src` over `region`, moved to start at voxel 0; voxels beyond
/// `region.max` are the background.
fn window_channel<T: Copy + PartialEq + Send + Sync>(src: &SparseGrid<T>, region: &IndexBox) -> SparseGrid<T> {
    let background = src.background();
    let size = region.max - region.min;
    let out_box = IndexBox::new(IVec3::ZERO, size);
    let aligned = region.min % BRICK_DIM == IVec3::ZERO;
    let shift = region.min.div_euclid(IVec3::splat(BRICK_DIM));
    let coords: Vec<IVec3> = IndexBox::new(IVec3::ZERO, brick_extent(size.as_uvec3()))
        .iter()
        .collect();
    let bricks: Vec<(IVec3, Brick<T>)> = coords
        .par_iter()
        .filter_map(|&b| {
            let own = brick_index_box(b);
            let whole = own.intersection(&out_box) == own;
            if aligned {
                let source = src.brick(b + shift)?;
                if whole {
                    return Some((b, source.clone()));
                }
            } else {
                // No source brick under this one: all background.
                let lo = (own.min + region.min).div_euclid(IVec3::splat(BRICK_DIM));
                let hi = (own.max - 1 + region.min).div_euclid(IVec3::splat(BRICK_DIM));
                if IndexBox::new(lo, hi + 1).iter().all(|s| src.brick(s).is_none()) {
                    return None;
                }
            }
            let brick = gather_brick(b, |ijk| {
                if out_box.contains(ijk) {
                    src.get(ijk + region.min)
                } else {
                    background
                }
            });
            (brick != Brick::Uniform(background)).then_some((b, brick))
        })
        .collect();
    let mut out = SparseGrid::new(background);
    for (b, brick) in bricks {
        out.insert_brick(b, brick);
    }
    out
}

/// Number of bricks along each axis needed to cover `dims` voxels.
pub fn brick_extent(dims: UVec3) -> IVec3 {
    ((dims + UVec3::splat(BRICK_DIM as u32 - 1)) / BRICK_DIM as u32).as_ivec3()
}

/// The bricks (brick coordinates) holding some voxel of `voxels` (index space); empty for
/// an empty box.
pub fn bricks_meeting(voxels: &IndexBox) -> IndexBox {
    if voxels.is_empty() {
        return IndexBox::new(IVec3::ZERO, IVec3::ZERO);
    }
    IndexBox::new(
        voxels.min.div_euclid(IVec3::splat(BRICK_DIM)),
        (voxels.max - 1).div_euclid(IVec3::splat(BRICK_DIM)) + 1,
    )
}

/// A collapsed brick holding `f(ijk)` for each voxel of brick `brick`.
pub fn gather_brick<T: Copy + PartialEq>(brick: IVec3, f: impl Fn(IVec3) -> T) -> Brick<T> {
    let base = brick * BRICK_DIM;
    let first = f(base);
    let mut data = [first; BRICK_VOXELS];
    for (i, ijk) in brick_index_box(brick).iter().enumerate() {
        data[i] = f(ijk);
    }
    debug_assert_eq!(
        Brick::<T>::local_offset(base + IVec3::new(1, 2, 3)),
        BRICK_SHAPE.linearize(IVec3::new(1, 2, 3))
    );
    Brick::from_voxels(&data)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Transform;
    use glam::DVec3;

    #[test]
    fn map_density_maps_every_voxel_and_the_background() {
        let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::new(20, 9, 9)).unwrap();
        let mut v = SparseVolume::new(grid, 3.0, false).with_density_kind(ChannelKind::SignedDistance);
        v.density.insert_brick(IVec3::new(1, 0, 0), Brick::Uniform(-3.0));
        v.density.set(IVec3::new(-1, 4, 17), 0.5);
        v.density.set(IVec3::new(2, 2, 2), -1.25);
        v.density.insert_brick(IVec3::new(2, 0, 0), Brick::Uniform(3.0));
        let m = v.map_density(|d| -2.0 * d);
        assert_eq!(m.density.background(), -6.0);
        assert_eq!(m.density_kind, ChannelKind::SignedDistance);
        for ijk in IndexBox::new(IVec3::splat(-8), IVec3::new(24, 16, 24)).iter() {
            assert_eq!(m.density.get(ijk), -2.0 * v.density.get(ijk), "{ijk}");
        }
        // The brick equal to the old background is dropped; the uniform one stays uniform.
        assert!(m.density.brick(IVec3::new(2, 0, 0)).is_none());
        assert_eq!(m.density.brick(IVec3::new(1, 0, 0)), Some(&Brick::Uniform(6.0)));
    }

    #[test]
    fn set_get_negative_and_prune() {
        let mut g = SparseGrid::new(0.0f32);
        g.set(IVec3::new(-1, -9, 17), 2.0);
        assert_eq!(g.get(IVec3::new(-1, -9, 17)), 2.0);
        assert_eq!(g.get(IVec3::new(-2, -9, 17)), 0.0);
        assert_eq!(brick_of(IVec3::new(-1, -9, 17)), IVec3::new(-1, -2, 2));
        g.set(IVec3::new(-1, -9, 17), 0.0);
        assert_eq!(g.brick_count(), 1);
        g.prune();
        assert_eq!(g.brick_count(), 0);
    }

    #[test]
    fn clones_share_bricks_and_writes_copy_only_the_written_brick() {
        let mut g = SparseGrid::new(0.0f32);
        for b in 0..4 {
            g.set(IVec3::new(8 * b, 0, 0), 1.0 + b as f32);
        }
        g.insert_brick(IVec3::new(0, 1, 0), Brick::Uniform(5.0));
        let before = g.clone();
        assert!(matches!(g.brick(IVec3::ZERO), Some(b) if b.is_shared()));
        assert!(g.changed_bricks(&before).is_empty());

        // Write into one shared brick: it is copied, the old version keeps its value.
        g.set(IVec3::new(9, 1, 1), 7.0);
        assert_eq!(before.get(IVec3::new(9, 1, 1)), 0.0);
        assert_eq!(g.get(IVec3::new(9, 1, 1)), 7.0);
        assert_eq!(g.get(IVec3::new(8, 0, 0)), 2.0);
        assert!(!g.brick(IVec3::new(1, 0, 0)).unwrap().is_shared());
        assert!(g.brick(IVec3::new(2, 0, 0)).unwrap().is_shared());
        // Writing the same brick again does not copy it again.
        let data = match g.brick(IVec3::new(1, 0, 0)) {
            Some(Brick::Dense(d)) => Arc::as_ptr(d),
            _ => panic!("dense brick expected"),
        };
        g.brick_data_mut(IVec3::new(1, 0, 0))[0] = 3.0;
        assert!(matches!(g.brick(IVec3::new(1, 0, 0)), Some(Brick::Dense(d)) if Arc::as_ptr(d) == data));

        // Changed bricks: the written one, a new one, a removed one, a new uniform value.
        g.set(IVec3::new(-1, 0, 0), 1.0);
        g.remove_brick(IVec3::new(3, 0, 0));
        g.insert_brick(IVec3::new(0, 1, 0), Brick::Uniform(6.0));
        let expected = vec![
            IVec3::new(-1, 0, 0),
            IVec3::new(1, 0, 0),
            IVec3::new(3, 0, 0),
            IVec3::new(0, 1, 0),
        ];
        assert_eq!(g.changed_bricks(&before), expected);
        assert_eq!(before.changed_bricks(&g), expected);
        // Undo by swapping in the kept version: only the listed bricks differ.
        for b in g.sorted_bricks().into_iter().chain(before.sorted_bricks()) {
            if !expected.contains(&b) {
                assert!(g.brick(b).unwrap().same_version(before.brick(b).unwrap()));
            }
        }
    }

    #[test]
    fn volume_channels_say_what_they_hold() {
        let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::new(4, 4, 4)).unwrap();
        let v = SparseVolume::new(grid, 0.0, true);
        assert_eq!(v.density_kind, ChannelKind::Density);
        assert_eq!(
            v.channels(),
            vec![("density", ChannelKind::Density), ("colour", ChannelKind::Colour)]
        );
        let d = SparseVolume::new(grid, 3.0, false).with_density_kind(ChannelKind::SignedDistance);
        assert_eq!(d.channels(), vec![("density", ChannelKind::SignedDistance)]);
        let mut e = d.clone();
        assert!(e.changed_bricks(&d).is_empty());
        e.density.set(IVec3::ONE, 0.0);
        assert_eq!(e.changed_bricks(&d), vec![IVec3::ZERO]);
    }

    #[test]
    fn dense_round_trip() {
        let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::new(11, 9, 3)).unwrap();
        let mut d = DenseVolume::new(grid, 0.0, true).unwrap();
        for (i, v) in d.density.as_mut_slice().iter_mut().enumerate() {
            *v = if i % 7 == 0 { i as f32 } else { 0.0 };
        }
        for (i, c) in d.colour.as_mut().unwrap().as_mut_slice().iter_mut().enumerate() {
            *c = [i as f32, 0.5, 0.0];
        }
        let s = SparseVolume::from_dense(&d);
        assert_eq!(s.to_dense().unwrap(), d);
        assert_eq!(
            s.active_voxel_count(),
            d.density.as_slice().iter().filter(|v| **v != 0.0).count() as u64
        );
        let ib = IndexBox::new(IVec3::new(0, 0, 0), IVec3::new(8, 1, 1));
        assert_eq!(s.density.range_in(&ib), (0.0, 7.0));
    }
}
