//! Reading `.vdb` float grids. The whole file is read (bounded by the caller's memory
//! limit) and parsed from memory: every count, size and offset is checked against the
//! bytes that remain before anything is allocated for it, node values decompress into
//! buffers of the size the tree dictates, and the memory the volume will need is checked
//! against the limit after the topology (which holds every node) and before any value
//! is decoded.

use glam::{DVec3, I64Vec3, IVec3};
use volga_core::{Brick, ChannelKind, Grid, SparseGrid, SparseVolume, Transform, BRICK_DIM, BRICK_VOXELS};

use super::format::*;
use super::VdbClass;

/// What went wrong, without the path (the caller adds it).
type Res<T> = Result<T, String>;

struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }
    fn take(&mut self, n: usize, what: &str) -> Res<&'a [u8]> {
        if n > self.remaining() {
            return Err(format!(
                "truncated at byte {}: {what} needs {n} bytes, {} remain",
                self.pos,
                self.remaining()
            ));
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn u8(&mut self, what: &str) -> Res<u8> {
        Ok(self.take(1, what)?[0])
    }
    fn u32(&mut self, what: &str) -> Res<u32> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn i32(&mut self, what: &str) -> Res<i32> {
        Ok(self.u32(what)? as i32)
    }
    fn i64(&mut self, what: &str) -> Res<i64> {
        let b = self.take(8, what)?;
        Ok(i64::from_le_bytes(b.try_into().expect("8 bytes")))
    }
    fn f64(&mut self, what: &str) -> Res<f64> {
        Ok(f64::from_bits(self.i64(what)? as u64))
    }
    fn vec3d(&mut self, what: &str) -> Res<DVec3> {
        Ok(DVec3::new(self.f64(what)?, self.f64(what)?, self.f64(what)?))
    }
    fn string(&mut self, what: &str) -> Res<String> {
        let n = self.u32(what)? as usize;
        let b = self.take(n, what)?;
        Ok(String::from_utf8_lossy(b).into_owned())
    }
    fn mask(&mut self, bits: usize, what: &str) -> Res<Mask> {
        let b = self.take(bits / 8, what)?;
        Ok(Mask {
            words: b
                .chunks_exact(8)
                .map(|w| u64::from_le_bytes(w.try_into().expect("8 bytes")))
                .collect(),
        })
    }
    fn value<T: VdbValue>(&mut self, what: &str) -> Res<T> {
        Ok(T::get(self.take(T::BYTES, what)?))
    }
}

/// One grid as found in the file.
#[derive(Debug, Clone)]
pub struct VdbGridInfo {
    /// The grid's name (its descriptor's, without the uniqueness suffix).
    pub name: String,
    /// The grid type, e.g. `Tree_float_5_4_3`, with `_HalfFloat` when saved as half.
    pub type_name: String,
}

/// A float grid read from a `.vdb` file into a [`SparseVolume`].
#[derive(Debug, Clone)]
pub struct VdbVolume {
    /// The voxels. Index space: the file's, shifted so the grid starts at voxel 0 (see
    /// [`read_vdb`](super::read_vdb)); world placement: the file's transform.
    pub volume: SparseVolume,
    /// The grid's name.
    pub name: String,
    /// The `class` metadata: level set, fog volume or unknown.
    pub class: VdbClass,
    /// Active voxels in the file (tiles counted by their voxels).
    pub active_voxels: u64,
    /// The file's index of the volume's voxel 0.
    pub index_offset: I64Vec3,
    /// Every grid in the file, the one read included.
    pub grids: Vec<VdbGridInfo>,
}

struct LeafIn {
    origin: IVec3,
    mask: Mask,
    values: Vec<f32>,
}

/// A tile: origin, edge length in voxels, value, active.
type TileIn = (IVec3, i32, f32, bool);

struct TreeIn {
    tiles: Vec<TileIn>,
    leaves: Vec<LeafIn>,
}

struct Stream {
    compression: u32,
    half: bool,
    background: f32,
}

/// `io::readData`: raw, or an `int64` size then a zlib stream or Blosc frame (a
/// non-positive size: `-size` raw bytes follow).
fn read_data(c: &mut Cursor, nbytes: usize, compression: u32) -> Res<Vec<u8>> {
    if compression & (COMPRESS_BLOSC | COMPRESS_ZIP) == 0 {
        return Ok(c.take(nbytes, "node values")?.to_vec());
    }
    let size = c.i64("a compressed chunk's size")?;
    if size <= 0 {
        let raw = size.unsigned_abs() as usize;
        if raw != nbytes {
            return Err(format!("a stored chunk of {raw} bytes where {nbytes} are expected"));
        }
        return Ok(c.take(nbytes, "node values")?.to_vec());
    }
    let packed = c.take(size as usize, "a compressed chunk")?;
    let mut out = vec![0u8; nbytes];
    if compression & COMPRESS_BLOSC != 0 {
        super::blosc::decompress(packed, &mut out)?;
    } else {
        let mut z = flate2::Decompress::new(true);
        let status = z
            .decompress(packed, &mut out, flate2::FlushDecompress::Finish)
            .map_err(|e| format!("corrupt zip chunk: {e}"))?;
        if z.total_out() as usize != nbytes || status != flate2::Status::StreamEnd {
            return Err(format!(
                "a zip chunk decodes to {} bytes or more where {nbytes} are expected",
                z.total_out()
            ));
        }
    }
    Ok(out)
}

/// `io::readCompressedValues` of `count` values of a node with `value_mask`.
fn read_values(c: &mut Cursor, s: &Stream, count: usize, value_mask: &Mask) -> Res<Vec<f32>> {
    let meta = c.u8("a node's compression metadata")?;
    if meta > NO_MASK_AND_ALL_VALS {
        return Err(format!("unknown node compression metadata {meta}"));
    }
    let bg = s.background;
    let mut inactive = [if meta == NO_MASK_OR_INACTIVE_VALS { bg } else { -bg }, bg];
    if matches!(
        meta,
        NO_MASK_AND_ONE_INACTIVE_VAL | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS
    ) {
        inactive[0] = c.value::<f32>("an inactive value")?;
        if meta == MASK_AND_TWO_INACTIVE_VALS {
            inactive[1] = c.value::<f32>("an inactive value")?;
        }
    }
    let selection = if matches!(
        meta,
        MASK_AND_NO_INACTIVE_VALS | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS
    ) {
        Some(c.mask(count, "a selection mask")?)
    } else {
        None
    };
    let mask_compressed = s.compression & COMPRESS_ACTIVE_MASK != 0;
    let stored = if mask_compressed && meta != NO_MASK_AND_ALL_VALS {
        value_mask.count_on()
    } else {
        count
    };
    let values: Vec<f32> = if s.half {
        if stored == 0 {
            Vec::new()
        } else {
            let b = read_data(c, stored * 2, s.compression)?;
            b.chunks_exact(2).map(f32::get_half).collect()
        }
    } else {
        let b = read_data(c, stored * 4, s.compression)?;
        b.chunks_exact(4).map(f32::get).collect()
    };
    if stored == count {
        return Ok(values);
    }
    let mut out = Vec::with_capacity(count);
    let mut it = values.into_iter();
    for i in 0..count {
        out.push(if value_mask.is_on(i) {
            it.next().expect("one stored value per active bit")
        } else if selection.as_ref().is_some_and(|m| m.is_on(i)) {
            inactive[1]
        } else {
            inactive[0]
        });
    }
    Ok(out)
}

/// Bytes the reader holds per tile and per leaf (its values, decoded later, and the
/// brick it becomes).
const TILE_BYTES: u64 = 24 + BRICK_ENTRY_BYTES;
const LEAF_BYTES: u64 = 64 + 4 * BRICK_VOXELS as u64 + BRICK_ENTRY_BYTES;

/// Memory the tree read so far will take, against the limit.
struct Budget {
    used: u64,
    max: u64,
}

impl Budget {
    fn spend(&mut self, bytes: u64) -> Res<()> {
        self.used += bytes;
        if self.used > self.max {
            return Err(format!(
                "the grid's nodes need more than the memory limit {} ({} bytes)",
                volga_core::memory::Bytes(self.max as u128),
                self.max
            ));
        }
        Ok(())
    }
}

/// Reads an internal node's topology (and, recursively, its children's), collecting
/// tiles and leaves within `budget`.
fn read_internal(
    c: &mut Cursor,
    s: &Stream,
    origin: IVec3,
    log2: i32,
    tree: &mut TreeIn,
    budget: &mut Budget,
) -> Res<()> {
    let child_log2 = if log2 == L2_LOG2 { L1_LOG2 } else { LEAF_LOG2 };
    let n = 1usize << (3 * (log2 - child_log2));
    let child_mask = c.mask(n, "a child mask")?;
    let value_mask = c.mask(n, "a value mask")?;
    let values = read_values(c, s, n, &value_mask)?;
    for (i, &v) in values.iter().enumerate() {
        if !child_mask.is_on(i) {
            let active = value_mask.is_on(i);
            if active || v != s.background {
                budget.spend(TILE_BYTES)?;
                let o = origin + IVec3::from_array(child_offset(i, log2, child_log2));
                tree.tiles.push((o, 1 << child_log2, v, active));
            }
        }
    }
    for i in child_mask.iter_on() {
        let o = origin + IVec3::from_array(child_offset(i, log2, child_log2));
        if child_log2 == LEAF_LOG2 {
            budget.spend(LEAF_BYTES)?;
            let mask = c.mask(512, "a leaf's value mask")?;
            tree.leaves.push(LeafIn {
                origin: o,
                mask,
                values: Vec::new(),
            });
        } else {
            read_internal(c, s, o, child_log2, tree, budget)?;
        }
    }
    Ok(())
}

fn grid_class(name: &str) -> VdbClass {
    match name {
        "level set" => VdbClass::LevelSet,
        "fog volume" => VdbClass::FogVolume,
        _ => VdbClass::Unknown,
    }
}

/// Reads the transform: scale and translation maps (an affine map without rotation or
/// shear included); anything else is refused.
fn read_transform(c: &mut Cursor) -> Res<(DVec3, DVec3)> {
    let map = c.string("the transform's map type")?;
    let (translation, scale) = match map.as_str() {
        "UniformScaleTranslateMap" | "ScaleTranslateMap" => {
            let t = c.vec3d("a translation")?;
            let s = c.vec3d("a scale")?;
            for _ in 0..4 {
                c.vec3d("a scale map's cached values")?;
            }
            (t, s)
        }
        "UniformScaleMap" | "ScaleMap" => {
            let s = c.vec3d("a scale")?;
            for _ in 0..4 {
                c.vec3d("a scale map's cached values")?;
            }
            (DVec3::ZERO, s)
        }
        "TranslationMap" => (c.vec3d("a translation")?, DVec3::ONE),
        "AffineMap" => {
            let mut m = [0.0f64; 16];
            for v in &mut m {
                *v = c.f64("an affine matrix")?;
            }
            // Row-vector convention: rows 0–2 the axes, row 3 the translation.
            let off_diagonal = [1, 2, 3, 4, 6, 7, 8, 9, 11].iter().any(|&i| m[i] != 0.0);
            if off_diagonal || m[15] != 1.0 {
                return Err(
                    "an affine transform with rotation, shear or projection is not supported \
                            (volga grids are axis-aligned)"
                        .into(),
                );
            }
            (DVec3::new(m[12], m[13], m[14]), DVec3::new(m[0], m[5], m[10]))
        }
        other => {
            return Err(format!(
                "transform map {other} is not supported (scale and translation only)"
            ))
        }
    };
    if !(scale.cmpgt(DVec3::ZERO).all() && scale.is_finite() && translation.is_finite()) {
        return Err(format!(
            "the transform's voxel size {scale} or translation {translation} is not positive and finite"
        ));
    }
    Ok((translation, scale))
}

/// Bytes of one stored brick in a [`SparseGrid`] map entry, besides dense values.
const BRICK_ENTRY_BYTES: u64 = 48;

/// Parses `bytes` (the file at `path`, for messages) and returns its first float grid.
pub(crate) fn parse(bytes: &[u8], max_bytes: u64) -> Res<VdbVolume> {
    let mut c = Cursor { bytes, pos: 0 };
    if c.i64("the magic number").ok() != Some(MAGIC) {
        return Err("not an OpenVDB file (bad magic number)".into());
    }
    let version = c.u32("the file version")?;
    if version > MAX_READ_VERSION {
        return Err(format!(
            "file format version {version} is newer than this reader knows ({MAX_READ_VERSION}, OpenVDB 11–12)"
        ));
    }
    if version < MIN_READ_VERSION {
        return Err(format!(
            "file format version {version} is older than this reader supports ({MIN_READ_VERSION}, OpenVDB 3+)"
        ));
    }
    c.u32("the library version")?;
    c.u32("the library version")?;
    let has_offsets = c.u8("the offsets flag")? != 0;
    c.take(36, "the UUID")?;
    skip_meta(&mut c)?;
    let count = c.i32("the grid count")?;
    if count < 0 || count as usize > c.remaining() / 16 {
        return Err(format!("implausible grid count {count}"));
    }
    let mut grids = Vec::new();
    let mut found: Option<(String, bool)> = None;
    for index in 0..count {
        let unique = c.string("a grid name")?;
        let name = unique.split('\u{1e}').next().unwrap_or_default().to_string();
        let type_name = c.string("a grid type")?;
        let parent = c.string("an instance parent")?;
        let _grid_pos = c.i64("a grid position")?;
        let _block_pos = c.i64("a block position")?;
        let end_pos = c.i64("an end position")?;
        grids.push(VdbGridInfo {
            name: name.clone(),
            type_name: type_name.clone(),
        });
        let base = type_name.strip_suffix(HALF_SUFFIX).unwrap_or(&type_name);
        if found.is_none() && base == "Tree_float_5_4_3" && parent.is_empty() {
            found = Some((name, type_name.ends_with(HALF_SUFFIX)));
            // List the grids after it, by their descriptors (best effort: a file
            // without offsets, or one cut short, lists fewer).
            if has_offsets {
                let mut rest = Cursor { bytes, pos: c.pos };
                let mut end = end_pos;
                for _ in index + 1..count {
                    if end < rest.pos as i64 || end as u64 > bytes.len() as u64 {
                        break;
                    }
                    rest.pos = end as usize;
                    let (Ok(unique), Ok(type_name), Ok(_), Ok(_), Ok(_), Ok(e)) = (
                        rest.string("a grid name"),
                        rest.string("a grid type"),
                        rest.string("an instance parent"),
                        rest.i64("a grid position"),
                        rest.i64("a block position"),
                        rest.i64("an end position"),
                    ) else {
                        break;
                    };
                    grids.push(VdbGridInfo {
                        name: unique.split('\u{1e}').next().unwrap_or_default().to_string(),
                        type_name,
                    });
                    end = e;
                }
            }
            break;
        }
        // Skip a grid this reader does not load.
        if !has_offsets {
            return Err(format!(
                "grid {name:?} of type {type_name} comes first and the file has no grid offsets to skip it"
            ));
        }
        if end_pos < c.pos as i64 || end_pos as u64 > bytes.len() as u64 {
            return Err(format!("grid {name:?} ends at byte {end_pos}, outside the file"));
        }
        c.pos = end_pos as usize;
    }
    let Some((name, half)) = found else {
        let list: Vec<String> = grids
            .iter()
            .map(|g| format!("{:?} ({})", g.name, g.type_name))
            .collect();
        return Err(format!(
            "no float grid to read (volga reads Tree_float_5_4_3 level sets and fog volumes); the file holds: {}",
            if list.is_empty() {
                "no grids".to_string()
            } else {
                list.join(", ")
            }
        ));
    };
    let compression = c.u32("the grid's compression flags")?;
    if compression & !(COMPRESS_ZIP | COMPRESS_ACTIVE_MASK | COMPRESS_BLOSC) != 0 {
        return Err(format!("unknown compression flags {compression:#x}"));
    }
    let class = grid_meta_class(&mut c)?;
    let (translation, scale) = read_transform(&mut c)?;
    let buffer_count = c.i32("the buffer count")?;
    if buffer_count != 1 {
        return Err(format!("{buffer_count} buffers per node (only 1 is supported)"));
    }
    let background = c.value::<f32>("the background")?;
    if !background.is_finite() {
        return Err(format!("the background {background} is not finite"));
    }
    let stream = Stream {
        compression,
        half,
        background,
    };
    let tiles = c.u32("the root's tile count")? as usize;
    let children = c.u32("the root's child count")? as usize;
    if tiles.saturating_mul(12 + 4 + 1) > c.remaining() || children.saturating_mul(12 + 8192) > c.remaining() {
        return Err(format!(
            "truncated or corrupt: {tiles} root tiles and {children} root children cannot fit in the {} bytes left",
            c.remaining()
        ));
    }
    let mut tree = TreeIn {
        tiles: Vec::new(),
        leaves: Vec::new(),
    };
    let mut budget = Budget {
        used: 0,
        max: max_bytes,
    };
    for _ in 0..tiles {
        let o = IVec3::new(c.i32("a tile")?, c.i32("a tile")?, c.i32("a tile")?);
        let v = c.value::<f32>("a tile value")?;
        let active = c.u8("a tile's state")? != 0;
        if o & IVec3::splat((1 << L2_LOG2) - 1) != IVec3::ZERO {
            return Err(format!("root tile at {o} is not aligned to 4096"));
        }
        if active || v != background {
            budget.spend(TILE_BYTES)?;
            tree.tiles.push((o, 1 << L2_LOG2, v, active));
        }
    }
    for _ in 0..children {
        let o = IVec3::new(
            c.i32("a child origin")?,
            c.i32("a child origin")?,
            c.i32("a child origin")?,
        );
        if o & IVec3::splat((1 << L2_LOG2) - 1) != IVec3::ZERO {
            return Err(format!("root child at {o} is not aligned to 4096"));
        }
        if o.cmpgt(IVec3::splat(i32::MAX - (1 << L2_LOG2))).any() {
            return Err(format!("root child at {o} lies at the end of the index range"));
        }
        read_internal(&mut c, &stream, o, L2_LOG2, &mut tree, &mut budget)?;
    }

    // The volume's extent: the active voxels' bounding box (in i64: index coordinates
    // span the whole i32 range).
    let mut bbox: Option<(I64Vec3, I64Vec3)> = None;
    let mut active_voxels = 0u64;
    let mut grow = |lo: I64Vec3, hi: I64Vec3| {
        bbox = Some(match bbox {
            None => (lo, hi),
            Some((a, b)) => (a.min(lo), b.max(hi)),
        })
    };
    for leaf in &tree.leaves {
        let on = leaf.mask.count_on();
        if on > 0 {
            active_voxels += on as u64;
            let (mut lo, mut hi) = (IVec3::splat(7), IVec3::ZERO);
            for n in leaf.mask.iter_on() {
                let p = IVec3::new((n >> 6) as i32, ((n >> 3) & 7) as i32, (n & 7) as i32);
                lo = lo.min(p);
                hi = hi.max(p);
            }
            grow((leaf.origin + lo).as_i64vec3(), (leaf.origin + hi).as_i64vec3());
        }
    }
    for &(o, size, _, active) in &tree.tiles {
        if active {
            active_voxels += (size as u64).pow(3);
            grow(o.as_i64vec3(), o.as_i64vec3() + I64Vec3::splat(size as i64 - 1));
        }
    }
    let Some((lo, hi)) = bbox else {
        return Err(format!("grid {name:?} has no active voxels"));
    };
    // Index space of the volume: volga's own files record their grid (voxel 0 at the
    // file's origin, `volga_grid_dims`); others start at the active box's brick corner.
    let (offset, dims) = match class.1 {
        Some(d) if lo.cmpge(I64Vec3::ZERO).all() && hi.cmplt(d.as_i64vec3()).all() => (I64Vec3::ZERO, d.as_i64vec3()),
        _ => {
            let offset: I64Vec3 = (lo >> 3i64) << 3i64;
            (offset, hi + I64Vec3::ONE - offset)
        }
    };
    if dims.cmpgt(I64Vec3::splat(u32::MAX as i64)).any() {
        return Err(format!(
            "the active voxels span {dims} voxels, more than a grid can hold"
        ));
    }
    // Memory before decoding any value: dense bricks for leaves, entries for tiles.
    let brick_lo: I64Vec3 = offset >> 3i64;
    let brick_hi: I64Vec3 = (offset + dims - I64Vec3::ONE) >> 3i64;
    let tile_bricks = |o: IVec3, size: i32| {
        let a = (o.as_i64vec3() >> 3i64).max(brick_lo);
        let b = ((o.as_i64vec3() + I64Vec3::splat(size as i64 - 1)) >> 3i64).min(brick_hi);
        (a, b)
    };
    let mut entries = tree.leaves.len() as u64;
    for &(o, size, ..) in &tree.tiles {
        let (a, b) = tile_bricks(o, size);
        if a.cmple(b).all() {
            let n = (b - a + I64Vec3::ONE).as_u64vec3();
            entries = entries.saturating_add(n.x.saturating_mul(n.y).saturating_mul(n.z));
        }
    }
    let needed = entries
        .saturating_mul(BRICK_ENTRY_BYTES)
        .saturating_add(tree.leaves.len() as u64 * BRICK_VOXELS as u64 * 4);
    if needed > max_bytes {
        return Err(format!(
            "the grid needs {} ({needed} bytes) as a volume, more than the memory limit {} ({max_bytes} bytes)",
            volga_core::memory::Bytes(needed as u128),
            volga_core::memory::Bytes(max_bytes as u128)
        ));
    }
    let dims_u = dims.as_uvec3();
    let origin = translation + scale * offset.as_dvec3();
    let grid = Transform::new(origin, scale)
        .and_then(|t| Grid::new(t, dims_u))
        .map_err(|e| format!("the grid {dims_u} at {origin} cannot be represented: {e}"))?;

    // Buffers: every leaf's values, in topology order.
    for leaf in &mut tree.leaves {
        c.mask(512, "a leaf's value mask")?;
        leaf.values = read_values(&mut c, &stream, 512, &leaf.mask)?;
        if let Some(i) = leaf.values.iter().position(|v| !v.is_finite()) {
            let p = leaf.origin + IVec3::new((i >> 6) as i32, ((i >> 3) & 7) as i32, (i & 7) as i32);
            return Err(format!("voxel {p} holds {}, not a finite value", leaf.values[i]));
        }
    }
    if let Some(t) = tree.tiles.iter().find(|t| !t.2.is_finite()) {
        return Err(format!("the tile at {} holds {}, not a finite value", t.0, t.2));
    }

    // Bricks in volga's index space (`file index − offset`), all within the i32 range
    // now that the extent fits the grid.
    let mut density = SparseGrid::new(background);
    for &(o, size, v, _) in &tree.tiles {
        let (a, b) = tile_bricks(o, size);
        for z in a.z..=b.z {
            for y in a.y..=b.y {
                for x in a.x..=b.x {
                    let brick = (I64Vec3::new(x, y, z) - brick_lo).as_ivec3();
                    density.insert_brick(brick, Brick::Uniform(v));
                }
            }
        }
    }
    for leaf in &tree.leaves {
        let brick = (leaf.origin.as_i64vec3() >> 3i64) - brick_lo;
        if brick.cmplt(I64Vec3::ZERO).any() || brick.cmpgt(brick_hi - brick_lo).any() {
            continue; // no active voxel, outside the extent
        }
        let mut data = [background; BRICK_VOXELS];
        for (n, v) in leaf.values.iter().enumerate() {
            let (x, y, z) = (n >> 6, (n >> 3) & 7, n & 7);
            data[x + BRICK_DIM as usize * (y + BRICK_DIM as usize * z)] = *v;
        }
        density.insert_brick(brick.as_ivec3(), Brick::from_voxels(&data));
    }
    let kind = match class.0 {
        VdbClass::LevelSet => ChannelKind::SignedDistance,
        _ => ChannelKind::Density,
    };
    let mut volume = SparseVolume::new(grid, background, false).with_density_kind(kind);
    volume.density = density;
    Ok(VdbVolume {
        volume,
        name,
        class: class.0,
        active_voxels,
        index_offset: offset,
        grids,
    })
}

/// Skips a metadata map (file-level).
fn skip_meta(c: &mut Cursor) -> Res<()> {
    read_meta(c, |_, _, _| {})
}

fn read_meta(c: &mut Cursor, mut f: impl FnMut(&str, &str, &[u8])) -> Res<()> {
    let count = c.u32("a metadata count")? as usize;
    if count > c.remaining() / 12 {
        return Err(format!("{count} metadata entries cannot fit in the file"));
    }
    for _ in 0..count {
        let name = c.string("a metadata name")?;
        let type_name = c.string("a metadata type")?;
        let size = c.u32("a metadata size")? as usize;
        let value = c.take(size, "a metadata value")?;
        f(&name, &type_name, value);
    }
    Ok(())
}

/// The grid's metadata: its class and, in volga's own files, the grid dimensions.
fn grid_meta_class(c: &mut Cursor) -> Res<(VdbClass, Option<IVec3>)> {
    let mut class = VdbClass::Unknown;
    let mut dims = None;
    read_meta(c, |name, type_name, value| match (name, type_name) {
        ("class", "string") => class = grid_class(&String::from_utf8_lossy(value)),
        ("volga_grid_dims", "vec3i") if value.len() == 12 => {
            let v = IVec3::new(
                i32::from_le_bytes(value[0..4].try_into().expect("4 bytes")),
                i32::from_le_bytes(value[4..8].try_into().expect("4 bytes")),
                i32::from_le_bytes(value[8..12].try_into().expect("4 bytes")),
            );
            if v.cmpgt(IVec3::ZERO).all() {
                dims = Some(v);
            }
        }
        _ => {}
    })?;
    Ok((class, dims))
}
