//! Writing `.vdb` files: the standard 5-4-3 tree built from volga's 8³ bricks (a brick
//! is exactly an OpenVDB leaf), uniform bricks and whole uniform nodes as tiles, node
//! values mask-compressed as OpenVDB's `io::writeCompressedValues` does, leaf buffers
//! compressed in parallel and concatenated in file order (the bytes do not depend on
//! the thread count).

use std::io::Write as _;

use glam::{DVec3, IVec3, UVec3};
use rayon::prelude::*;
use volga_core::{Brick, SparseGrid, BRICK_DIM};

use super::format::*;
use super::{VdbClass, VdbCompression, VdbOptions};

/// One grid to write: which voxels (`0 ≤ ijk < dims`) of which channel, and how a
/// stored value maps to the value written and its active state.
pub(crate) struct GridIn<'a, T> {
    pub name: &'a str,
    pub class: VdbClass,
    pub values: &'a SparseGrid<T>,
    pub dims: UVec3,
    pub background: T,
    /// `(value written, active)` of a voxel inside the grid.
    pub classify: &'a (dyn Fn(T) -> (T, bool) + Sync),
    /// `vector_type` metadata of a vector grid.
    pub vector_type: Option<&'a str>,
}

struct Leaf<T> {
    mask: Mask,
    values: Vec<T>,
}

enum Slot<C, T> {
    Child(C),
    Tile(T, bool),
}

struct Internal<C, T> {
    child_mask: Mask,
    value_mask: Mask,
    values: Vec<T>,
    children: Vec<C>,
}

type L1<T> = Internal<Leaf<T>, T>;
type L2<T> = Internal<L1<T>, T>;
/// Root entries: origin and the 4096³ node or tile there.
type RootEntries<T> = Vec<([i32; 3], Slot<L2<T>, T>)>;
/// Nodes (or tiles) of one level, by node key.
type Level<C, T> = Vec<(IVec3, Slot<Internal<C, T>, T>)>;

/// The tree of one grid, with its statistics.
struct Tree<T> {
    background: T,
    root: RootEntries<T>,
    active_voxels: u64,
    bbox: Option<(IVec3, IVec3)>,
    leaves: usize,
    l1: usize,
    l2: usize,
}

fn grow(bbox: &mut Option<(IVec3, IVec3)>, lo: IVec3, hi: IVec3) {
    *bbox = Some(match *bbox {
        None => (lo, hi),
        Some((a, b)) => (a.min(lo), b.max(hi)),
    });
}

/// The leaf or tile of brick `b`, `None` when it holds only inactive background.
fn brick_slot<T: VdbValue>(g: &GridIn<T>, b: IVec3) -> Option<Slot<Leaf<T>, T>> {
    let brick = g.values.brick(b)?;
    let dims = g.dims.as_ivec3();
    let base = b * BRICK_DIM;
    if base.cmpge(dims).any() || (base + BRICK_DIM).cmple(IVec3::ZERO).any() {
        return None;
    }
    let whole = base.cmpge(IVec3::ZERO).all() && (base + BRICK_DIM).cmple(dims).all();
    let bg = (g.background, false);
    if let (Brick::Uniform(v), true) = (brick, whole) {
        let (v, a) = (g.classify)(*v);
        return ((v, a) != bg).then_some(Slot::Tile(v, a));
    }
    let mut mask = Mask::new(512);
    let mut values = vec![g.background; 512];
    for z in 0..BRICK_DIM {
        for y in 0..BRICK_DIM {
            for x in 0..BRICK_DIM {
                let ijk = base + IVec3::new(x, y, z);
                let (v, a) = if ijk.cmpge(IVec3::ZERO).all() && ijk.cmplt(dims).all() {
                    (g.classify)(brick.get_local(Brick::<T>::local_offset(ijk)))
                } else {
                    bg
                };
                let n = ((x << 6) | (y << 3) | z) as usize;
                values[n] = v;
                if a {
                    mask.set_on(n);
                }
            }
        }
    }
    let on = mask.count_on();
    if values.iter().all(|v| *v == values[0]) && (on == 0 || on == 512) {
        let tile = (values[0], on == 512);
        return (tile != bg).then_some(Slot::Tile(tile.0, tile.1));
    }
    Some(Slot::Child(Leaf { mask, values }))
}

/// Groups child slots (sorted by their node key, then child index) into internal nodes
/// of `2^(log2 - child_log2)` children per axis; a node whose entries are all one tile
/// becomes that tile one level up, a node of inactive background disappears.
fn group<C, T: VdbValue>(
    items: Vec<(IVec3, usize, Slot<C, T>)>,
    log2: i32,
    child_log2: i32,
    background: T,
) -> Level<C, T> {
    let n = 1usize << (3 * (log2 - child_log2));
    let mut out = Vec::new();
    let mut iter = items.into_iter().peekable();
    while let Some((key, idx, slot)) = iter.next() {
        let mut node = Internal {
            child_mask: Mask::new(n),
            value_mask: Mask::new(n),
            values: vec![background; n],
            children: Vec::new(),
        };
        let mut put = |idx: usize, slot: Slot<C, T>| match slot {
            Slot::Child(c) => {
                node.child_mask.set_on(idx);
                node.values[idx] = T::zero();
                node.children.push(c);
            }
            Slot::Tile(v, a) => {
                node.values[idx] = v;
                if a {
                    node.value_mask.set_on(idx);
                }
            }
        };
        put(idx, slot);
        while let Some((_, idx, slot)) = iter.next_if(|(k, _, _)| *k == key) {
            put(idx, slot);
        }
        let on = node.value_mask.count_on();
        let uniform =
            node.children.is_empty() && (on == 0 || on == n) && node.values.iter().all(|v| *v == node.values[0]);
        if uniform {
            let tile = (node.values[0], on == n);
            if tile != (background, false) {
                out.push((key, Slot::Tile(tile.0, tile.1)));
            }
        } else {
            out.push((key, Slot::Child(node)));
        }
    }
    out
}

fn lex(v: IVec3) -> (i32, i32, i32) {
    (v.x, v.y, v.z)
}

fn build<T: VdbValue>(g: &GridIn<T>) -> Tree<T> {
    let ext = volga_core::brick_extent(g.dims);
    let bricks: Vec<IVec3> = g
        .values
        .sorted_bricks()
        .into_iter()
        .filter(|b| b.cmpge(IVec3::ZERO).all() && b.cmplt(ext).all())
        .collect();
    let mut slots: Vec<(IVec3, Slot<Leaf<T>, T>)> = bricks
        .par_iter()
        .filter_map(|&b| brick_slot(g, b).map(|s| (b, s)))
        .collect();
    // Order: root key (x, y, z), then L1 index, then leaf index.
    slots.sort_unstable_by_key(|(b, _)| {
        let ijk = (*b * BRICK_DIM).to_array();
        (
            lex(*b >> (L2_LOG2 - LEAF_LOG2)),
            child_index(ijk, L2_LOG2, L1_LOG2),
            child_index(ijk, L1_LOG2, LEAF_LOG2),
        )
    });
    let mut active_voxels = 0u64;
    let mut bbox = None;
    let mut leaves = 0;
    for (b, s) in &slots {
        match s {
            Slot::Child(leaf) => {
                leaves += 1;
                active_voxels += leaf.mask.count_on() as u64;
                for n in leaf.mask.iter_on() {
                    let p = *b * BRICK_DIM + IVec3::new((n >> 6) as i32, ((n >> 3) & 7) as i32, (n & 7) as i32);
                    grow(&mut bbox, p, p);
                }
            }
            Slot::Tile(_, true) => {
                active_voxels += 512;
                grow(&mut bbox, *b * BRICK_DIM, *b * BRICK_DIM + IVec3::splat(BRICK_DIM - 1));
            }
            Slot::Tile(_, false) => {}
        }
    }
    let l1_items = slots
        .into_iter()
        .map(|(b, s)| {
            let ijk = (b * BRICK_DIM).to_array();
            (b >> (L1_LOG2 - LEAF_LOG2), child_index(ijk, L1_LOG2, LEAF_LOG2), s)
        })
        .collect();
    let l1 = group(l1_items, L1_LOG2, LEAF_LOG2, g.background);
    let l2_items = l1
        .into_iter()
        .map(|(k, s)| {
            let ijk = (k << L1_LOG2).to_array();
            (k >> (L2_LOG2 - L1_LOG2), child_index(ijk, L2_LOG2, L1_LOG2), s)
        })
        .collect();
    let l2 = group(l2_items, L2_LOG2, L1_LOG2, g.background);
    let mut root: RootEntries<T> = l2.into_iter().map(|(k, s)| ((k << L2_LOG2).to_array(), s)).collect();
    root.sort_unstable_by_key(|(o, _)| (o[0], o[1], o[2]));
    let l1 = root
        .iter()
        .map(|(_, s)| match s {
            Slot::Child(n) => n.children.len(),
            Slot::Tile(..) => 0,
        })
        .sum();
    let l2 = root.iter().filter(|(_, s)| matches!(s, Slot::Child(_))).count();
    Tree {
        background: g.background,
        root,
        active_voxels,
        bbox,
        leaves,
        l1,
        l2,
    }
}

fn put_i32(out: &mut Vec<u8>, v: i32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_i64(out: &mut Vec<u8>, v: i64) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_string(out: &mut Vec<u8>, s: &str) {
    put_u32(out, s.len() as u32);
    out.extend_from_slice(s.as_bytes());
}

/// `io::writeData` of already encoded values: raw, or an `int64` size and a zlib
/// stream or Blosc frame (a negative size when the data did not shrink, then raw).
fn put_data(out: &mut Vec<u8>, bytes: &[u8], compression: u32) {
    let packed = if compression & COMPRESS_BLOSC != 0 {
        super::blosc::compress(bytes)
    } else if compression & COMPRESS_ZIP != 0 {
        let mut z =
            flate2::write::ZlibEncoder::new(Vec::with_capacity(bytes.len() / 2), flate2::Compression::default());
        z.write_all(bytes).expect("writing to memory");
        Some(z.finish().expect("writing to memory")).filter(|p| p.len() < bytes.len())
    } else {
        out.extend_from_slice(bytes);
        return;
    };
    match packed {
        Some(p) => {
            put_i64(out, p.len() as i64);
            out.extend_from_slice(&p);
        }
        None => {
            put_i64(out, -(bytes.len() as i64));
            out.extend_from_slice(bytes);
        }
    }
}

/// `io::writeCompressedValues`: the per-node metadata byte, the inactive values and
/// selection mask it calls for, then the active values only (or all of them when the
/// inactive ones take more than two values), compressed.
fn put_values<T: VdbValue>(
    out: &mut Vec<u8>,
    values: &[T],
    value_mask: &Mask,
    child_mask: Option<&Mask>,
    background: T,
    half: bool,
    compression: u32,
) {
    // MaskCompress: the distinct inactive values (child slots skipped), up to three.
    let mut inactive = [background; 2];
    let mut unique = 0;
    for (i, &v) in values.iter().enumerate() {
        if value_mask.is_on(i) || child_mask.is_some_and(|m| m.is_on(i)) {
            continue;
        }
        let seen = (unique > 0 && v == inactive[0]) || (unique > 1 && v == inactive[1]);
        if !seen {
            if unique < 2 {
                inactive[unique] = v;
            }
            unique += 1;
            if unique > 2 {
                break;
            }
        }
    }
    let neg = background.negated();
    let mut meta = NO_MASK_OR_INACTIVE_VALS;
    if unique == 1 {
        if inactive[0] != background {
            meta = if inactive[0] == neg {
                NO_MASK_AND_MINUS_BG
            } else {
                NO_MASK_AND_ONE_INACTIVE_VAL
            };
        }
    } else if unique == 2 {
        if inactive[0] != background && inactive[1] != background {
            meta = MASK_AND_TWO_INACTIVE_VALS;
        } else if inactive[1] == background {
            meta = if inactive[0] == neg {
                MASK_AND_NO_INACTIVE_VALS
            } else {
                MASK_AND_ONE_INACTIVE_VAL
            };
        } else {
            // inactive[0] is the background: swap so that [1] is.
            meta = if inactive[1] == neg {
                MASK_AND_NO_INACTIVE_VALS
            } else {
                MASK_AND_ONE_INACTIVE_VAL
            };
            inactive.swap(0, 1);
        }
    } else if unique > 2 {
        meta = NO_MASK_AND_ALL_VALS;
    }
    out.push(meta);
    let put_full = |out: &mut Vec<u8>, v: T| if half { v.truncated().put(out) } else { v.put(out) };
    if matches!(
        meta,
        NO_MASK_AND_ONE_INACTIVE_VAL | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS
    ) {
        put_full(out, inactive[0]);
        if meta == MASK_AND_TWO_INACTIVE_VALS {
            put_full(out, inactive[1]);
        }
    }
    let mut kept: Vec<T> = Vec::with_capacity(values.len());
    if meta == NO_MASK_AND_ALL_VALS {
        kept.extend_from_slice(values);
    } else {
        let mut selection = Mask::new(values.len());
        for (i, v) in values.iter().enumerate() {
            if value_mask.is_on(i) {
                kept.push(*v);
            } else if *v == inactive[1] {
                selection.set_on(i);
            }
        }
        if matches!(
            meta,
            MASK_AND_NO_INACTIVE_VALS | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS
        ) {
            selection.put(out);
        }
    }
    if half && kept.is_empty() {
        return; // HalfWriter writes nothing for no values
    }
    let mut bytes = Vec::with_capacity(kept.len() * if half { T::HALF_BYTES } else { T::BYTES });
    for v in kept {
        if half {
            v.put_half(&mut bytes)
        } else {
            v.put(&mut bytes)
        }
    }
    if bytes.is_empty() && compression & (COMPRESS_ZIP | COMPRESS_BLOSC) != 0 {
        put_i64(out, 0);
        return;
    }
    put_data(out, &bytes, compression);
}

fn compression_flags(c: VdbCompression) -> u32 {
    COMPRESS_ACTIVE_MASK
        | match c {
            VdbCompression::None => 0,
            VdbCompression::Zip => COMPRESS_ZIP,
            VdbCompression::Blosc => COMPRESS_BLOSC,
        }
}

fn compression_name(flags: u32) -> String {
    let mut parts = Vec::new();
    if flags & COMPRESS_ZIP != 0 {
        parts.push("zip");
    }
    if flags & COMPRESS_BLOSC != 0 {
        parts.push("blosc");
    }
    if flags & COMPRESS_ACTIVE_MASK != 0 {
        parts.push("active values");
    }
    if parts.is_empty() {
        "none".into()
    } else {
        parts.join(" + ")
    }
}

enum Meta<'a> {
    Str(&'a str),
    Bool(bool),
    I64(i64),
    Vec3i(IVec3),
}

fn put_meta(out: &mut Vec<u8>, entries: &[(&str, Meta)]) {
    put_u32(out, entries.len() as u32);
    for (name, m) in entries {
        put_string(out, name);
        match m {
            Meta::Str(s) => {
                put_string(out, "string");
                put_string(out, s);
            }
            Meta::Bool(b) => {
                put_string(out, "bool");
                put_u32(out, 1);
                out.push(*b as u8);
            }
            Meta::I64(v) => {
                put_string(out, "int64");
                put_u32(out, 8);
                put_i64(out, *v);
            }
            Meta::Vec3i(v) => {
                put_string(out, "vec3i");
                put_u32(out, 12);
                for c in v.to_array() {
                    put_i32(out, c);
                }
            }
        }
    }
}

/// Bytes OpenVDB's `Grid::memUsage` reports for a tree of this shape (leaf: buffer,
/// mask and origin; internal nodes: their tables and masks), for `file_mem_bytes`.
fn mem_bytes<T: VdbValue>(tree: &Tree<T>) -> i64 {
    let v = std::mem::size_of::<T>().max(8) as i64;
    let leaf = 512 * T::BYTES as i64 + 64 + 12 + 16;
    let l1 = 4096 * v + 2 * 512 + 12;
    let l2 = 32768 * v + 2 * 4096 + 12;
    tree.leaves as i64 * leaf + tree.l1 as i64 * l1 + tree.l2 as i64 * l2 + 64 + tree.root.len() as i64 * 48
}

/// Appends one grid (descriptor, metadata, transform, topology, buffers) to `out`,
/// filling in its stream positions.
pub(crate) fn put_grid<T: VdbValue>(
    out: &mut Vec<u8>,
    g: &GridIn<T>,
    origin: DVec3,
    spacing: DVec3,
    options: &VdbOptions,
) {
    let half = options.half;
    let flags = compression_flags(options.compression);
    let tree = build(g);

    put_string(out, g.name);
    let mut type_name = format!("Tree_{}_5_4_3", T::TYPE);
    if half {
        type_name.push_str(HALF_SUFFIX);
    }
    put_string(out, &type_name);
    put_string(out, "");
    let positions_at = out.len();
    out.extend_from_slice(&[0u8; 24]);
    let grid_pos = out.len();
    put_u32(out, flags);

    let (bmin, bmax) = tree.bbox.unwrap_or((IVec3::MAX, IVec3::MIN));
    let compression = compression_name(flags);
    let creator = format!("volga {}", env!("CARGO_PKG_VERSION"));
    let mut meta = vec![
        ("class", Meta::Str(g.class.name())),
        ("creator", Meta::Str(&creator)),
        ("file_bbox_max", Meta::Vec3i(bmax)),
        ("file_bbox_min", Meta::Vec3i(bmin)),
        ("file_compression", Meta::Str(&compression)),
        ("file_mem_bytes", Meta::I64(mem_bytes(&tree))),
        ("file_voxel_count", Meta::I64(tree.active_voxels as i64)),
    ];
    if half {
        meta.push(("is_saved_as_half_float", Meta::Bool(true)));
    }
    meta.push(("name", Meta::Str(g.name)));
    if let Some(t) = g.vector_type {
        meta.push(("vector_type", Meta::Str(t)));
    }
    meta.push(("volga_grid_dims", Meta::Vec3i(g.dims.as_ivec3())));
    put_meta(out, &meta);

    // Transform: index (voxel centres at integers) to world, scale then translation.
    let uniform = spacing.x == spacing.y && spacing.y == spacing.z;
    put_string(
        out,
        if uniform {
            "UniformScaleTranslateMap"
        } else {
            "ScaleTranslateMap"
        },
    );
    for v in [
        origin,
        spacing,
        spacing.abs(),
        1.0 / spacing,
        1.0 / (spacing * spacing),
        0.5 / spacing,
    ] {
        for c in v.to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }

    // Topology.
    let bg = tree.background;
    put_i32(out, 1); // buffer count
    if half {
        bg.truncated().put(out)
    } else {
        bg.put(out)
    }
    let tiles = tree.root.iter().filter(|(_, s)| matches!(s, Slot::Tile(..))).count();
    put_u32(out, tiles as u32);
    put_u32(out, (tree.root.len() - tiles) as u32);
    for (o, s) in &tree.root {
        if let Slot::Tile(v, a) = s {
            o.iter().for_each(|c| put_i32(out, *c));
            v.put(out);
            out.push(*a as u8);
        }
    }
    let mut leaves: Vec<&Leaf<T>> = Vec::with_capacity(tree.leaves);
    for (o, s) in &tree.root {
        let Slot::Child(l2) = s else { continue };
        o.iter().for_each(|c| put_i32(out, *c));
        put_internal(out, l2, bg, half, flags);
        for l1 in &l2.children {
            put_internal(out, l1, bg, half, flags);
            for leaf in &l1.children {
                leaf.mask.put(out);
                leaves.push(leaf);
            }
        }
    }
    // Buffers: leaves in the same order, compressed in parallel.
    let block_pos = out.len();
    let buffers: Vec<Vec<u8>> = leaves
        .par_iter()
        .map(|leaf| {
            let mut b = Vec::with_capacity(64 + 1 + 512 * T::BYTES + 8);
            leaf.mask.put(&mut b);
            put_values(&mut b, &leaf.values, &leaf.mask, None, bg, half, flags);
            b
        })
        .collect();
    out.reserve(buffers.iter().map(Vec::len).sum());
    for b in buffers {
        out.extend_from_slice(&b);
    }
    let end_pos = out.len();
    for (i, p) in [grid_pos, block_pos, end_pos].into_iter().enumerate() {
        out[positions_at + 8 * i..positions_at + 8 * i + 8].copy_from_slice(&(p as i64).to_le_bytes());
    }
}

fn put_internal<C, T: VdbValue>(out: &mut Vec<u8>, node: &Internal<C, T>, bg: T, half: bool, flags: u32) {
    node.child_mask.put(out);
    node.value_mask.put(out);
    put_values(
        out,
        &node.values,
        &node.value_mask,
        Some(&node.child_mask),
        bg,
        half,
        flags,
    );
}

/// Offset and length of the UUID in the header.
pub(crate) const UUID_AT: usize = 21;
pub(crate) const UUID_LEN: usize = 36;

/// Sets the header's UUID to one derived from the file's contents after the header
/// (equal files, equal UUIDs: output does not depend on the run).
pub(crate) fn stamp_uuid(file: &mut [u8]) {
    let hash = |seed: u64| {
        file[UUID_AT + UUID_LEN..]
            .iter()
            .fold(seed, |h, b| (h ^ *b as u64).wrapping_mul(0x0000_0100_0000_01B3))
    };
    let h = ((hash(0xcbf2_9ce4_8422_2325) as u128) << 64) | hash(0x84222325_cbf29ce4) as u128;
    let hex = format!("{h:032X}");
    let uuid = format!(
        "{}-{}-{}-{}-{}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    );
    file[UUID_AT..UUID_AT + UUID_LEN].copy_from_slice(uuid.as_bytes());
}

/// The file header: magic, format and library versions, offsets flag, a placeholder
/// UUID ([`stamp_uuid`] sets it), no file-level metadata, grid count.
pub(crate) fn header(grid_count: u32) -> Vec<u8> {
    let mut out = Vec::new();
    put_i64(&mut out, MAGIC);
    put_u32(&mut out, FILE_VERSION);
    put_u32(&mut out, 10);
    put_u32(&mut out, 0);
    out.push(1); // grid offsets present
    out.extend_from_slice(&[b'0'; UUID_LEN]);
    put_u32(&mut out, 0); // file metadata: none
    put_i32(&mut out, grid_count as i32);
    out
}
