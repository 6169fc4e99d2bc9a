//! Constants and value encodings shared by the `.vdb` reader and writer (OpenVDB's
//! `version.h`, `io/Compression.h`).

/// `OPENVDB_MAGIC`, stored as an `int64`.
pub(crate) const MAGIC: i64 = 0x5644_4220;
/// The file format volga writes: OpenVDB 10's (`OPENVDB_FILE_VERSION_MULTIPASS_IO`).
pub(crate) const FILE_VERSION: u32 = 224;
/// The oldest file format read: per-grid compression and node-mask compression.
pub(crate) const MIN_READ_VERSION: u32 = 222;
/// The newest file format read (OpenVDB 11+: `HALF_GRID`).
pub(crate) const MAX_READ_VERSION: u32 = 225;

pub(crate) const COMPRESS_ZIP: u32 = 0x1;
pub(crate) const COMPRESS_ACTIVE_MASK: u32 = 0x2;
pub(crate) const COMPRESS_BLOSC: u32 = 0x4;

/// Per-node value metadata (`io::Compression.h`): what the inactive values are and
/// whether a selection mask follows.
pub(crate) const NO_MASK_OR_INACTIVE_VALS: u8 = 0;
pub(crate) const NO_MASK_AND_MINUS_BG: u8 = 1;
pub(crate) const NO_MASK_AND_ONE_INACTIVE_VAL: u8 = 2;
pub(crate) const MASK_AND_NO_INACTIVE_VALS: u8 = 3;
pub(crate) const MASK_AND_ONE_INACTIVE_VAL: u8 = 4;
pub(crate) const MASK_AND_TWO_INACTIVE_VALS: u8 = 5;
pub(crate) const NO_MASK_AND_ALL_VALS: u8 = 6;

/// Grid type suffix of grids saved as half floats.
pub(crate) const HALF_SUFFIX: &str = "_HalfFloat";

/// Log2 of the voxels a node spans per axis: leaf 3 (8³), internal 7 (128³) and 12
/// (4096³), the standard 5-4-3 tree.
pub(crate) const LEAF_LOG2: i32 = 3;
pub(crate) const L1_LOG2: i32 = 7;
pub(crate) const L2_LOG2: i32 = 12;

/// Index of a child inside a node of `2^(log2 - child_log2)` children per axis, z
/// fastest (OpenVDB's `coordToOffset`).
#[inline]
pub(crate) fn child_index(ijk: [i32; 3], log2: i32, child_log2: i32) -> usize {
    let n = log2 - child_log2;
    let m = (1 << n) - 1;
    let c = |v: i32| ((v >> child_log2) & m) as usize;
    (c(ijk[0]) << (2 * n)) | (c(ijk[1]) << n) | c(ijk[2])
}

/// The offset (in voxels, from the node origin) of child `index` (inverse of
/// [`child_index`]).
#[inline]
pub(crate) fn child_offset(index: usize, log2: i32, child_log2: i32) -> [i32; 3] {
    let n = log2 - child_log2;
    let m = (1usize << n) - 1;
    [
        (((index >> (2 * n)) & m) as i32) << child_log2,
        (((index >> n) & m) as i32) << child_log2,
        ((index & m) as i32) << child_log2,
    ]
}

/// A voxel value OpenVDB can store: its type name, byte encodings (full and half
/// precision, little endian) and the operations node compression needs.
pub(crate) trait VdbValue: Copy + PartialEq + Send + Sync + std::fmt::Debug + 'static {
    /// The value type in the grid type name (`Tree_{TYPE}_5_4_3`).
    const TYPE: &'static str;
    /// Bytes of one value at full precision.
    const BYTES: usize;
    /// Bytes of one value saved as half float.
    const HALF_BYTES: usize;
    fn zero() -> Self;
    fn put(self, out: &mut Vec<u8>);
    fn put_half(self, out: &mut Vec<u8>);
    /// The value rounded through half precision (`io::truncateRealToHalf`).
    fn truncated(self) -> Self;
    fn negated(self) -> Self;
    /// Decodes a value from `BYTES` (or `HALF_BYTES`) bytes.
    fn get(b: &[u8]) -> Self;
    fn get_half(b: &[u8]) -> Self;
}

#[inline]
fn f32_at(b: &[u8], i: usize) -> f32 {
    f32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]])
}

#[inline]
fn f16_at(b: &[u8], i: usize) -> f32 {
    half::f16::from_le_bytes([b[2 * i], b[2 * i + 1]]).to_f32()
}

impl VdbValue for f32 {
    const TYPE: &'static str = "float";
    const BYTES: usize = 4;
    const HALF_BYTES: usize = 2;
    fn zero() -> Self {
        0.0
    }
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
    fn put_half(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&half::f16::from_f32(self).to_le_bytes());
    }
    fn truncated(self) -> Self {
        half::f16::from_f32(self).to_f32()
    }
    fn negated(self) -> Self {
        -self
    }
    fn get(b: &[u8]) -> Self {
        f32_at(b, 0)
    }
    fn get_half(b: &[u8]) -> Self {
        f16_at(b, 0)
    }
}

impl VdbValue for [f32; 3] {
    const TYPE: &'static str = "vec3s";
    const BYTES: usize = 12;
    const HALF_BYTES: usize = 6;
    fn zero() -> Self {
        [0.0; 3]
    }
    fn put(self, out: &mut Vec<u8>) {
        for c in self {
            c.put(out);
        }
    }
    fn put_half(self, out: &mut Vec<u8>) {
        for c in self {
            c.put_half(out);
        }
    }
    fn truncated(self) -> Self {
        self.map(VdbValue::truncated)
    }
    fn negated(self) -> Self {
        self.map(|c| -c)
    }
    fn get(b: &[u8]) -> Self {
        [f32_at(b, 0), f32_at(b, 1), f32_at(b, 2)]
    }
    fn get_half(b: &[u8]) -> Self {
        [f16_at(b, 0), f16_at(b, 1), f16_at(b, 2)]
    }
}

/// A bit mask of `words.len() · 64` bits, bit `n` in word `n / 64` (OpenVDB's
/// `NodeMask`, saved as its words).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Mask {
    pub(crate) words: Vec<u64>,
}

impl Mask {
    pub(crate) fn new(bits: usize) -> Self {
        Mask {
            words: vec![0; bits / 64],
        }
    }
    #[inline]
    pub(crate) fn is_on(&self, n: usize) -> bool {
        self.words[n >> 6] >> (n & 63) & 1 == 1
    }
    #[inline]
    pub(crate) fn set_on(&mut self, n: usize) {
        self.words[n >> 6] |= 1 << (n & 63);
    }
    pub(crate) fn count_on(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }
    pub(crate) fn put(&self, out: &mut Vec<u8>) {
        for w in &self.words {
            out.extend_from_slice(&w.to_le_bytes());
        }
    }
    /// Indices of the bits set, in increasing order.
    pub(crate) fn iter_on(&self) -> impl Iterator<Item = usize> + '_ {
        self.words.iter().enumerate().flat_map(|(i, &w)| {
            let mut w = w;
            std::iter::from_fn(move || {
                (w != 0).then(|| {
                    let b = w.trailing_zeros() as usize;
                    w &= w - 1;
                    i * 64 + b
                })
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn child_indices_are_z_fastest_and_invert() {
        assert_eq!(child_index([0, 0, 1], LEAF_LOG2, 0), 1);
        assert_eq!(child_index([0, 1, 0], LEAF_LOG2, 0), 8);
        assert_eq!(child_index([1, 0, 0], LEAF_LOG2, 0), 64);
        assert_eq!(child_index([-8, 8, 16], L1_LOG2, LEAF_LOG2), (15 << 8) | (1 << 4) | 2);
        for i in [0usize, 1, 77, 4095] {
            let o = child_offset(i, L1_LOG2, LEAF_LOG2);
            assert_eq!(child_index(o, L1_LOG2, LEAF_LOG2), i);
        }
        let mut m = Mask::new(512);
        for n in [0, 63, 64, 511] {
            m.set_on(n);
        }
        assert_eq!(m.iter_on().collect::<Vec<_>>(), vec![0, 63, 64, 511]);
        assert_eq!(m.count_on(), 4);
    }
}
