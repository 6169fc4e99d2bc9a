//! A voxel source packed for the renderer's fast path: per voxel its density **and** its
//! central-difference gradient, four `f32` side by side, in padded tiles behind a flat
//! table. A trilinear sample of value and gradient together is then one table read,
//! eight 16-byte loads and seven 4-wide lerps, instead of a 4×4×4 stencil and four
//! trilinear reconstructions.
//!
//! Why this equals the central-difference gradient of the trilinear reconstruction:
//! that gradient ([`GradientMethod::CentralDifference`](volga_core::GradientMethod) with
//! [`Filter::Trilinear`](volga_core::Filter)) is, per axis, the trilinear interpolation of
//! the voxels' own differences `(v[i + 1] − v[i − 1]) / 2h` at the cell's eight corners
//! (see `filters::trilinear_central_gradient`). Storing those per-voxel differences
//! and interpolating them gives the same quantity, rounded to `f32` once per voxel.

use std::collections::HashMap;

use glam::{DVec3, IVec3, Vec3, Vec4};
use rayon::prelude::*;

use volga_core::{Field, Filter, GradientMethod, Grid, IndexBox, Shape3, VoxelBlock, MAX_ATLAS_BYTES};

const TILE_LOG2: i32 = 4;
const TILE: i32 = 1 << TILE_LOG2;
/// Stored tile edge: the tile's 16 voxels plus one after (the far corners of a cell).
const PADDED: i32 = TILE + 1;
const PADDED_VOXELS: usize = (PADDED * PADDED * PADDED) as usize;
const STRIDE_Y: usize = PADDED as usize;
const STRIDE_Z: usize = (PADDED * PADDED) as usize;
/// Stored coordinates are `ijk + SHIFT`, so base voxels from `−SHIFT` on are served:
/// a ray clipped to the sampled bounds has base voxels in `[−1, dims]`, and one more on
/// each side absorbs the rounding of positions at the bounds.
const SHIFT: i32 = 2;

/// One stored voxel: density, then the world-space central-difference gradient
/// `((v[i+1] − v[i−1]) / 2hx, …)`, as `[v, gx, gy, gz]`.
pub type PackedVoxel = [f32; 4];

/// A voxel source's densities and central-difference gradients, packed for ray
/// sampling (see the [module docs](self)). Built from the voxels
/// ([`Field::voxels`](volga_core::Field::voxels)) of a trilinear, central-difference
/// [`Sampled`](volga_core::Sampled) field; read-only.
///
/// Densities are the source's own `f32` (the same bits), so [`PackedVolume::value`]
/// equals the trilinear [`Sampled`](volga_core::Sampled)'s value bit for bit; gradients are
/// the same formula rounded to `f32` per voxel (relative error ~1e-7).
pub struct PackedVolume {
    grid: Grid,
    background: f32,
    /// Tiles per axis: `ceil((dims + 2·SHIFT) / 16)`.
    tiles: IVec3,
    /// `tiles · 16` as `u32`: a stored base coordinate in `[0, extent)` is served.
    extent: [u32; 3],
    /// Tile (x fastest) → first voxel of its padded block in `voxels`.
    table: Vec<u32>,
    /// First voxel of a block holding the background with a zero gradient: the cell
    /// [`PackedVolume::sample_lanes`] reads outside the stored region.
    background_offset: u32,
    voxels: Vec<PackedVoxel>,
}

/// Where eight samples read ([`PackedVolume::cells_avx2`]): per lane the offset of the
/// cell's base voxel entry (the background block's outside the stored region) and the
/// fractions per axis, with the length of the volume's storage they were located in:
/// [`PackedVolume::sample_cells_avx2`] refuses cells of any other length, so offsets
/// located in one volume never read beyond another. The default belongs to no volume
/// (a placeholder; sampling it panics).
#[derive(Clone, Copy, Debug, Default)]
pub struct LaneCells {
    offset: [u32; 8],
    frac: [[f32; 8]; 3],
    /// `voxels.len()` of the volume that located them.
    voxel_len: usize,
}

/// Where a trilinear sample reads: the offset of its base voxel's entry (or `None`
/// outside the stored region, where every corner is the background with a zero
/// gradient) and the fractions.
#[derive(Clone, Copy, Debug)]
pub struct PackedCell {
    pub offset: Option<usize>,
    pub fraction: DVec3,
}

impl PackedVolume {
    /// The packed copy of `field`'s voxels when the field is their trilinear
    /// reconstruction with central-difference gradients (what a packed sample
    /// reproduces, see [`Field::voxels`]); `None` for any other field, filter or gradient
    /// method, or if the copy would exceed [`MAX_ATLAS_BYTES`].
    pub fn of_field<F: Field + ?Sized>(field: &F) -> Option<Self> {
        let voxels = field.voxels()?;
        if voxels.filter != Filter::Trilinear || voxels.gradient != GradientMethod::CentralDifference {
            return None;
        }
        Self::build(&*voxels.source)
    }

    /// Packs `source`, or `None` if the copy would take more than
    /// [`MAX_ATLAS_BYTES`] (checked before allocating). Tiles whose voxels and
    /// neighbours are one finite value share one stored tile. Filled in parallel; the
    /// result does not depend on the thread count.
    pub fn build(source: &dyn VoxelBlock) -> Option<Self> {
        let grid = *source.block_grid();
        let dims = grid.dims().as_ivec3();
        let tiles = (dims + IVec3::splat(2 * SHIFT + TILE - 1)) >> TILE_LOG2;
        let n = tiles.as_uvec3().as_u64vec3().element_product();
        if n >= u32::MAX as u64 {
            return None;
        }
        let tile_shape = Shape3::new(tiles.as_uvec3()).ok()?;
        let bg = source.block_background();
        // Per tile: its value if every voxel it stores and their six neighbours are
        // one finite value (gradients then all exactly zero).
        let uniform: Vec<Option<f32>> = (0..n as usize)
            .into_par_iter()
            .map(|tile| {
                let first = tile_shape.delinearize(tile) * TILE - IVec3::splat(SHIFT) - IVec3::ONE;
                let needed = IndexBox::new(first, first + IVec3::splat(PADDED + 2));
                let inside = needed.intersection(&grid.index_box());
                let (mut lo, mut hi) = if inside.is_empty() {
                    (bg, bg)
                } else {
                    source.block_range(&inside)
                };
                if inside != needed {
                    lo = lo.min(bg);
                    hi = hi.max(bg);
                }
                (lo.to_bits() == hi.to_bits() && lo.is_finite()).then_some(lo)
            })
            .collect();
        let mut slot_of_value: HashMap<u32, u32> = HashMap::new();
        let mut fills: Vec<(Option<f32>, usize)> = Vec::new(); // per slot: uniform value or the tile to copy
        let mut table = Vec::with_capacity(uniform.len());
        for (tile, u) in uniform.iter().enumerate() {
            let slot = match u {
                Some(v) => *slot_of_value.entry(v.to_bits()).or_insert_with(|| {
                    fills.push((Some(*v), tile));
                    (fills.len() - 1) as u32
                }),
                None => {
                    fills.push((None, tile));
                    (fills.len() - 1) as u32
                }
            };
            table.push(slot);
        }
        // The block served to samples outside the stored region (the background with a
        // zero gradient): the uniform background tile if there is one, else a new one.
        let background_slot = match slot_of_value.get(&bg.to_bits()) {
            Some(&slot) if bg.is_finite() => slot,
            _ => {
                fills.push((Some(bg), 0));
                (fills.len() - 1) as u32
            }
        };
        let bytes = fills.len() as u64 * (PADDED_VOXELS * 16) as u64 + table.len() as u64 * 4;
        if bytes > MAX_ATLAS_BYTES || (fills.len() as u64) * (PADDED_VOXELS as u64) >= u32::MAX as u64 {
            return None;
        }
        let table = table.into_iter().map(|s| s * PADDED_VOXELS as u32).collect();
        let inv_two_h = (2.0 * grid.transform.spacing()).recip();
        let mut voxels = vec![[0.0f32; 4]; fills.len() * PADDED_VOXELS];
        voxels
            .par_chunks_mut(PADDED_VOXELS)
            .zip(fills.par_iter())
            .for_each(|(block, &(fill, tile))| match fill {
                Some(v) => block.fill([v, 0.0, 0.0, 0.0]),
                None => {
                    // The densities the block needs: one voxel beyond it on every side.
                    const E: usize = (PADDED + 2) as usize;
                    let first = tile_shape.delinearize(tile) * TILE - IVec3::splat(SHIFT);
                    let mut d = vec![0.0f32; E * E * E];
                    let lo = first - IVec3::ONE;
                    source.read_block(&IndexBox::new(lo, lo + IVec3::splat(E as i32)), &mut d);
                    let at = |x: usize, y: usize, z: usize| d[x + E * (y + E * z)] as f64;
                    for (o, out) in block.iter_mut().enumerate() {
                        let (x, y, z) = (o % STRIDE_Y + 1, (o / STRIDE_Y) % STRIDE_Y + 1, o / STRIDE_Z + 1);
                        *out = [
                            at(x, y, z) as f32,
                            ((at(x + 1, y, z) - at(x - 1, y, z)) * inv_two_h.x) as f32,
                            ((at(x, y + 1, z) - at(x, y - 1, z)) * inv_two_h.y) as f32,
                            ((at(x, y, z + 1) - at(x, y, z - 1)) * inv_two_h.z) as f32,
                        ];
                    }
                }
            });
        Some(PackedVolume {
            grid,
            background: bg,
            background_offset: background_slot * PADDED_VOXELS as u32,
            tiles,
            extent: (tiles * TILE).as_uvec3().to_array(),
            table,
            voxels,
        })
    }

    /// The grid of the packed source.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The source's background density.
    pub fn background(&self) -> f32 {
        self.background
    }

    /// Offset of base voxel `base`'s entry; its cell's eight corners are at
    /// `offset + {0, 1} + {0, STRIDE_Y} + {0, STRIDE_Z}`. `None` outside the stored
    /// region, where all eight corners are background voxels whose neighbours are
    /// background too.
    #[inline(always)]
    pub fn offset(&self, base: IVec3) -> Option<usize> {
        let s = (base + IVec3::splat(SHIFT)).as_uvec3();
        if !(s.x < self.extent[0] && s.y < self.extent[1] && s.z < self.extent[2]) {
            return None;
        }
        let t = s >> TILE_LOG2 as u32;
        let tile = t.x as usize + self.tiles.x as usize * (t.y as usize + self.tiles.y as usize * t.z as usize);
        let local = s & glam::UVec3::splat(TILE as u32 - 1);
        Some(self.table[tile] as usize + local.x as usize + STRIDE_Y * local.y as usize + STRIDE_Z * local.z as usize)
    }

    /// The base voxel and fractions of continuous index coordinates (as
    /// [`Sampled`](volga_core::Sampled) computes them).
    ///
    /// The floor is taken through one `i32` conversion per axis (on coordinates clamped
    /// to ±10⁹, far outside any grid): the same base voxel and fractions as
    /// [`fast_floor`](volga_core::fast_floor) inside that range, and the background beyond it either way.
    #[inline(always)]
    pub fn cell_at_index(&self, index_pos: DVec3) -> PackedCell {
        const LIM: f64 = 1e9;
        let c = index_pos.clamp(DVec3::splat(-LIM), DVec3::splat(LIM));
        let floor = |x: f64| {
            let t = x as i32; // NaN → 0, like `fast_floor`
            t - ((t as f64) > x) as i32
        };
        let base = IVec3::new(floor(c.x), floor(c.y), floor(c.z));
        PackedCell {
            offset: self.offset(base),
            fraction: index_pos - base.as_dvec3(),
        }
    }

    /// The eight corner entries of the cell at `offset` (x fastest).
    #[inline(always)]
    pub fn corners(&self, offset: usize) -> [Vec4; 8] {
        let v = &self.voxels[offset..offset + STRIDE_Z + STRIDE_Y + 2];
        let l = |i: usize| Vec4::from_array(v[i]);
        [
            l(0),
            l(1),
            l(STRIDE_Y),
            l(STRIDE_Y + 1),
            l(STRIDE_Z),
            l(STRIDE_Z + 1),
            l(STRIDE_Z + STRIDE_Y),
            l(STRIDE_Z + STRIDE_Y + 1),
        ]
    }

    /// Density and gradient `[v, gx, gy, gz]` interpolated trilinearly in `f32` (one
    /// 4-wide lerp per pair of corners: seven in all).
    #[inline(always)]
    pub fn sample4(&self, cell: &PackedCell) -> Vec4 {
        match cell.offset {
            None => Vec4::new(self.background, 0.0, 0.0, 0.0),
            Some(o) => {
                let c = self.corners(o);
                let f = cell.fraction.as_vec3();
                let (fx, fy, fz) = (Vec4::splat(f.x), Vec4::splat(f.y), Vec4::splat(f.z));
                let x00 = c[0] + (c[1] - c[0]) * fx;
                let x10 = c[2] + (c[3] - c[2]) * fx;
                let x01 = c[4] + (c[5] - c[4]) * fx;
                let x11 = c[6] + (c[7] - c[6]) * fx;
                let y0 = x00 + (x10 - x00) * fy;
                let y1 = x01 + (x11 - x01) * fy;
                y0 + (y1 - y0) * fz
            }
        }
    }

    /// Per lane: the offset of the cell's base voxel entry (the background block's
    /// outside the stored region or at non-finite positions) and the fractions.
    // Index loops over the lanes on purpose; `max(..).min(..)` rather than `clamp`,
    // which keeps NaN.
    #[allow(clippy::needless_range_loop, clippy::manual_clamp)]
    #[inline(always)]
    fn cells_lanes(&self, index_pos: &[[f32; 8]; 3]) -> ([u32; 8], [[f32; 8]; 3]) {
        // Clamping sends NaN to −LIM (`f32::max` returns the non-NaN operand) and ±∞ to
        // ±LIM: outside the stored region, with fraction 0.
        const LIM: f32 = 1e9;
        let mut frac = [[0.0f32; 8]; 3];
        let mut stored = [[0u32; 8]; 3];
        let mut outside = [0u32; 8];
        for a in 0..3 {
            let extent = self.extent[a];
            for l in 0..8 {
                let x = index_pos[a][l].max(-LIM).min(LIM);
                let f = x.floor();
                frac[a][l] = x - f;
                let s = (f as i32).wrapping_add(SHIFT) as u32;
                stored[a][l] = s;
                outside[l] |= (s >= extent) as u32;
            }
        }
        let (tx, ty) = (self.tiles.x as u32, self.tiles.y as u32);
        let last = self.table.len() - 1;
        let mut offset = [0u32; 8];
        for l in 0..8 {
            let (sx, sy, sz) = (stored[0][l], stored[1][l], stored[2][l]);
            // Wrapping and clamped: a lane outside the stored region reads some entry,
            // unused.
            let tile = (sx >> TILE_LOG2)
                .wrapping_add(tx.wrapping_mul((sy >> TILE_LOG2).wrapping_add(ty.wrapping_mul(sz >> TILE_LOG2))));
            let local = (sx & 15) + STRIDE_Y as u32 * (sy & 15) + STRIDE_Z as u32 * (sz & 15);
            let entry = self.table[(tile as usize).min(last)];
            offset[l] = if outside[l] == 0 {
                entry + local
            } else {
                self.background_offset
            };
        }
        (offset, frac)
    }

    /// Where eight samples at continuous index coordinates (per axis in `f32` lanes)
    /// read: [`PackedVolume::cells_lanes`] in AVX2 vectors, to prefetch
    /// ([`PackedVolume::prefetch_cells_avx2`]) and later sample
    /// ([`PackedVolume::sample_cells_avx2`]) without computing it twice.
    ///
    /// # Safety
    /// As [`PackedVolume::sample_lanes_avx2`]: the CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub unsafe fn cells_avx2(&self, index_pos: &[[f32; 8]; 3]) -> LaneCells {
        // SAFETY: the caller guarantees AVX2.
        let (offset, frac) = unsafe { self.cells_lanes_avx2(index_pos) };
        LaneCells {
            offset,
            frac,
            voxel_len: self.voxels.len(),
        }
    }

    /// Prefetches into L1 the corner rows that [`PackedVolume::sample_cells_avx2`] will
    /// read for `cells` (issued a couple of packets ahead of the fetch).
    ///
    /// # Safety
    /// As [`PackedVolume::sample_lanes_avx2`]: the CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub unsafe fn prefetch_cells_avx2(&self, cells: &LaneCells) {
        use std::arch::x86_64::*;
        let base = self.voxels.as_ptr() as *const i8;
        for o in cells.offset {
            let o = o as usize * 16;
            for d in [0, 16 * STRIDE_Y, 16 * STRIDE_Z, 16 * (STRIDE_Z + STRIDE_Y)] {
                // A prefetch never faults; the address is inside `voxels` anyway (see
                // `sample_cells_avx2`).
                _mm_prefetch::<_MM_HINT_T0>(base.wrapping_add(o + d));
            }
        }
    }

    /// [`PackedVolume::cells_lanes`] in AVX2 vectors: the same clamp, floor, tile
    /// lookup (one gather from the table) and in-region test, so the same offsets and
    /// fractions bit for bit. The portable loop compiles to one scalar saturating
    /// conversion and table read per lane (callgrind: 38 of its 49 instructions per
    /// sample were the conversion and the index arithmetic).
    ///
    /// # Safety
    /// As [`PackedVolume::sample_lanes_avx2`]: the CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn cells_lanes_avx2(&self, index_pos: &[[f32; 8]; 3]) -> ([u32; 8], [[f32; 8]; 3]) {
        use std::arch::x86_64::*;
        const LIM: f32 = 1e9;
        let mut frac = [[0.0f32; 8]; 3];
        let mut stored = [_mm256_setzero_si256(); 3];
        let mut outside = _mm256_setzero_si256();
        for a in 0..3 {
            // SAFETY: `index_pos[a]` is an `[f32; 8]`, 32 readable bytes; unaligned load.
            let x = unsafe { _mm256_loadu_ps(index_pos[a].as_ptr()) };
            // `maxps` returns its second operand when either is NaN: NaN → −LIM, as
            // `f32::max` in the portable loop.
            let x = _mm256_min_ps(_mm256_max_ps(x, _mm256_set1_ps(-LIM)), _mm256_set1_ps(LIM));
            let f = _mm256_floor_ps(x);
            // SAFETY: `frac[a]` is an `[f32; 8]`, 32 writable bytes; unaligned store.
            unsafe { _mm256_storeu_ps(frac[a].as_mut_ptr(), _mm256_sub_ps(x, f)) };
            // `f` is a whole number within ±10⁹: the truncation is exact, as `f as i32`.
            let s = _mm256_add_epi32(_mm256_cvttps_epi32(f), _mm256_set1_epi32(SHIFT));
            stored[a] = s;
            // Unsigned `s ≥ extent` ⟺ `max(s, extent) = s`.
            let extent = _mm256_set1_epi32(self.extent[a] as i32);
            outside = _mm256_or_si256(outside, _mm256_cmpeq_epi32(_mm256_max_epu32(s, extent), s));
        }
        let [sx, sy, sz] = stored;
        let tx = _mm256_set1_epi32(self.tiles.x);
        let ty = _mm256_set1_epi32(self.tiles.y);
        let tile = _mm256_add_epi32(
            _mm256_srli_epi32::<TILE_LOG2>(sx),
            _mm256_mullo_epi32(
                tx,
                _mm256_add_epi32(
                    _mm256_srli_epi32::<TILE_LOG2>(sy),
                    _mm256_mullo_epi32(ty, _mm256_srli_epi32::<TILE_LOG2>(sz)),
                ),
            ),
        );
        let tile = _mm256_min_epu32(tile, _mm256_set1_epi32((self.table.len() - 1) as i32));
        let low = _mm256_set1_epi32(TILE - 1);
        let local = _mm256_add_epi32(
            _mm256_and_si256(sx, low),
            _mm256_add_epi32(
                _mm256_mullo_epi32(_mm256_and_si256(sy, low), _mm256_set1_epi32(STRIDE_Y as i32)),
                _mm256_mullo_epi32(_mm256_and_si256(sz, low), _mm256_set1_epi32(STRIDE_Z as i32)),
            ),
        );
        // SAFETY: every lane of `tile` is at most `table.len() − 1` (clamped just
        // above), so the gather reads inside `table`.
        let entry = unsafe { _mm256_i32gather_epi32::<4>(self.table.as_ptr() as *const i32, tile) };
        let offset = _mm256_blendv_epi8(
            _mm256_add_epi32(entry, local),
            _mm256_set1_epi32(self.background_offset as i32),
            outside,
        );
        let mut out = [0u32; 8];
        // SAFETY: `out` is a `[u32; 8]`, 32 writable bytes; unaligned store.
        unsafe { _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, offset) };
        (out, frac)
    }

    /// Density and gradient of eight samples at once, at continuous index coordinates
    /// given per axis in `f32` lanes: `(v, [gx, gy, gz])` per lane.
    ///
    /// The trilinear blend of [`PackedVolume::sample4`] in another order (the two
    /// x-neighbours of a corner row are one 8-wide lerp in y, then in z, then the
    /// halves in x), so a lane differs from `sample4` by rounding only (a few `f32`
    /// ulps). Every step is lane-wise and branch-free: the floor, the tile lookup and
    /// the in-region test run across the lanes, and a lane outside the stored region
    /// reads the background block (the same value and zero gradient `sample4` gives).
    /// Positions must be finite; non-finite lanes read the background.
    // Index loops over the lanes on purpose: they are what the compiler vectorizes.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    pub fn sample_lanes(&self, index_pos: &[[f32; 8]; 3]) -> ([f32; 8], [[f32; 8]; 3]) {
        let (offset, frac) = self.cells_lanes(index_pos);
        let flat = self.voxels.as_flattened();
        let mut v = [0.0f32; 8];
        let mut g = [[0.0f32; 8]; 3];
        for l in 0..8 {
            let o = offset[l] as usize * 4;
            let row = |d: usize| -> [f32; 8] { flat[o + 4 * d..o + 4 * d + 8].try_into().unwrap() };
            let (r00, r10, r01, r11) = (row(0), row(STRIDE_Y), row(STRIDE_Z), row(STRIDE_Z + STRIDE_Y));
            let (fx, fy, fz) = (frac[0][l], frac[1][l], frac[2][l]);
            let mut r = [0.0f32; 8];
            for c in 0..8 {
                let y0 = r00[c] + (r10[c] - r00[c]) * fy;
                let y1 = r01[c] + (r11[c] - r01[c]) * fy;
                r[c] = y0 + (y1 - y0) * fz;
            }
            let mut q = [0.0f32; 4];
            for c in 0..4 {
                q[c] = r[c] + (r[c + 4] - r[c]) * fx;
            }
            v[l] = q[0];
            g[0][l] = q[1];
            g[1][l] = q[2];
            g[2][l] = q[3];
        }
        (v, g)
    }

    /// [`PackedVolume::sample_lanes`] for CPUs with AVX2: the same operations in the
    /// same order (no fused multiply-adds), so the same bits, with each lane's four
    /// corner rows read as 8-wide vectors and the lanes transposed by shuffles.
    ///
    /// # Safety
    /// The CPU must support AVX2 (`is_x86_feature_detected!("avx2")`), and the
    /// caller should be compiled with it (`#[target_feature(enable = "avx2")]`): the
    /// function is always inlined into its caller (which a target-feature function
    /// cannot be), so its intrinsics compile to the caller's instructions.
    #[cfg(all(test, target_arch = "x86_64"))]
    #[inline(always)]
    pub unsafe fn sample_lanes_avx2(&self, index_pos: &[[f32; 8]; 3]) -> ([f32; 8], [[f32; 8]; 3]) {
        // SAFETY: the caller guarantees AVX2 (this function's own contract).
        unsafe { self.sample_cells_avx2(&self.cells_avx2(index_pos)) }
    }

    /// [`PackedVolume::sample_lanes_avx2`] at cells already located
    /// ([`PackedVolume::cells_avx2`]): the same bits.
    ///
    /// Panics if `cells` were located in a volume whose storage has another length
    /// (cells of this volume, or of one laid out alike, only read inside it).
    ///
    /// # Safety
    /// As [`PackedVolume::sample_lanes_avx2`]: the CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub unsafe fn sample_cells_avx2(&self, cells: &LaneCells) -> ([f32; 8], [[f32; 8]; 3]) {
        use std::arch::x86_64::*;
        assert_eq!(
            cells.voxel_len,
            self.voxels.len(),
            "lane cells of another packed volume"
        );
        let (offset, frac) = (&cells.offset, &cells.frac);
        let base = self.voxels.as_ptr() as *const f32;
        let mut q = [_mm_setzero_ps(); 8];
        for l in 0..8 {
            let o = offset[l] as usize * 4;
            debug_assert!(o + 4 * (STRIDE_Z + STRIDE_Y + 2) <= self.voxels.len() * 4);
            // SAFETY: `offset[l]` is a base voxel entry of a stored padded block of a
            // volume with this storage length (asserted above; `LaneCells` are made
            // only by `cells_avx2`): a table entry plus a local offset below 16 per axis,
            // or the background block's first entry. Its cell's far corner
            // `+ STRIDE_Z + STRIDE_Y + 1` lies in the same block, inside `voxels`;
            // unaligned loads need no alignment.
            let (r00, r10, r01, r11) = unsafe {
                (
                    _mm256_loadu_ps(base.add(o)),
                    _mm256_loadu_ps(base.add(o + 4 * STRIDE_Y)),
                    _mm256_loadu_ps(base.add(o + 4 * STRIDE_Z)),
                    _mm256_loadu_ps(base.add(o + 4 * (STRIDE_Z + STRIDE_Y))),
                )
            };
            let fy = _mm256_set1_ps(frac[1][l]);
            let fz = _mm256_set1_ps(frac[2][l]);
            let y0 = _mm256_add_ps(r00, _mm256_mul_ps(_mm256_sub_ps(r10, r00), fy));
            let y1 = _mm256_add_ps(r01, _mm256_mul_ps(_mm256_sub_ps(r11, r01), fy));
            let r = _mm256_add_ps(y0, _mm256_mul_ps(_mm256_sub_ps(y1, y0), fz));
            let (lo, hi) = (_mm256_castps256_ps128(r), _mm256_extractf128_ps::<1>(r));
            q[l] = _mm_add_ps(lo, _mm_mul_ps(_mm_sub_ps(hi, lo), _mm_set1_ps(frac[0][l])));
        }
        // Transpose the lanes' [v, gx, gy, gz] into four 8-lane vectors.
        let t0 = _mm256_set_m128(q[4], q[0]);
        let t1 = _mm256_set_m128(q[5], q[1]);
        let t2 = _mm256_set_m128(q[6], q[2]);
        let t3 = _mm256_set_m128(q[7], q[3]);
        let u0 = _mm256_unpacklo_ps(t0, t1);
        let u1 = _mm256_unpackhi_ps(t0, t1);
        let u2 = _mm256_unpacklo_ps(t2, t3);
        let u3 = _mm256_unpackhi_ps(t2, t3);
        let rows = [
            _mm256_shuffle_ps::<0x44>(u0, u2),
            _mm256_shuffle_ps::<0xEE>(u0, u2),
            _mm256_shuffle_ps::<0x44>(u1, u3),
            _mm256_shuffle_ps::<0xEE>(u1, u3),
        ];
        let mut out = [[0.0f32; 8]; 4];
        for (o, r) in out.iter_mut().zip(rows) {
            // SAFETY: `o` is an `[f32; 8]`, 32 writable bytes; unaligned store.
            unsafe { _mm256_storeu_ps(o.as_mut_ptr(), r) };
        }
        (out[0], [out[1], out[2], out[3]])
    }

    /// The trilinear value at continuous index coordinates, in `f64` exactly as
    /// [`Sampled`](volga_core::Sampled) computes it (the same bits).
    #[inline(always)]
    pub fn value_at_index(&self, index_pos: DVec3) -> f64 {
        let cell = self.cell_at_index(index_pos);
        let c = match cell.offset {
            None => [self.background as f64; 8],
            Some(o) => self.corners(o).map(|c| c.x as f64),
        };
        let f = cell.fraction;
        let x00 = c[0] + (c[1] - c[0]) * f.x;
        let x10 = c[2] + (c[3] - c[2]) * f.x;
        let x01 = c[4] + (c[5] - c[4]) * f.x;
        let x11 = c[6] + (c[7] - c[6]) * f.x;
        let y0 = x00 + (x10 - x00) * f.y;
        let y1 = x01 + (x11 - x01) * f.y;
        y0 + (y1 - y0) * f.z
    }

    /// The trilinear value at a world position (the same bits as the trilinear
    /// [`Sampled::value`](volga_core::Field::value)).
    #[inline(always)]
    pub fn value(&self, world_pos: DVec3) -> f64 {
        self.value_at_index(self.grid.transform.world_to_index(world_pos))
    }

    /// The central-difference gradient of the trilinear reconstruction at a world
    /// position, from the per-voxel gradients (within `f32` rounding of
    /// [`Sampled::gradient`](volga_core::Field::gradient)).
    #[inline(always)]
    pub fn gradient(&self, world_pos: DVec3) -> DVec3 {
        let g = self.sample4(&self.cell_at_index(self.grid.transform.world_to_index(world_pos)));
        Vec3::new(g.y, g.z, g.w).as_dvec3()
    }
}

#[cfg(test)]
#[path = "packed_tests.rs"]
mod tests;
