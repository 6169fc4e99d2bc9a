//! The Blosc 1 frame OpenVDB stores compressed node values in (`COMPRESS_BLOSC`): a
//! 16-byte header, block offsets, and per block one or `typesize` LZ4 streams of the
//! byte-shuffled values. Decoding covers what c-blosc 1.x writes with the LZ4 codec
//! (OpenVDB's choice) and plain copies; encoding writes one unsplit LZ4 block, shuffled
//! with `typesize` 4 as OpenVDB does, which every c-blosc since 1.x decodes.
//!
//! Layout (c-blosc `blosc.c`): header `version, versionlz, flags, typesize` then
//! `nbytes, blocksize, cbytes` (u32 little endian); flags: 0x1 byte shuffle, 0x2 plain
//! copy, 0x4 bit shuffle, 0x10 blocks not split, bits 5–7 the codec (1 = LZ4).

const HEADER: usize = 16;
const FLAG_SHUFFLE: u8 = 0x1;
const FLAG_MEMCPYED: u8 = 0x2;
const FLAG_BITSHUFFLE: u8 = 0x4;
const FLAG_DONT_SPLIT: u8 = 0x10;
const CODEC_LZ4: u8 = 1;
const MAX_SPLITS: usize = 16;
const MIN_BUFFERSIZE: usize = 128;

/// Decodes a Blosc frame into `out`, whose length must be the frame's uncompressed size.
/// Every offset and size is checked against the frame: a hostile frame is an error,
/// never a panic or an allocation beyond `out.len()` plus one block.
pub(crate) fn decompress(src: &[u8], out: &mut [u8]) -> Result<(), String> {
    if src.len() < HEADER {
        return Err(format!(
            "a Blosc frame of {} bytes is shorter than its header",
            src.len()
        ));
    }
    let flags = src[2];
    let typesize = src[3] as usize;
    let u32_at = |i: usize| u32::from_le_bytes([src[i], src[i + 1], src[i + 2], src[i + 3]]) as usize;
    let (nbytes, blocksize, cbytes) = (u32_at(4), u32_at(8), u32_at(12));
    if nbytes != out.len() {
        return Err(format!(
            "a Blosc frame holds {nbytes} bytes where {} are expected",
            out.len()
        ));
    }
    if cbytes > src.len() {
        return Err(format!("a Blosc frame claims {cbytes} bytes but {} remain", src.len()));
    }
    let src = &src[..cbytes];
    if flags & FLAG_MEMCPYED != 0 {
        let data = src
            .get(HEADER..HEADER + nbytes)
            .ok_or("a copied Blosc frame is truncated")?;
        out.copy_from_slice(data);
        return Ok(());
    }
    if nbytes == 0 {
        return Ok(());
    }
    if flags & FLAG_BITSHUFFLE != 0 {
        return Err("Blosc bit-shuffled data is not supported (OpenVDB writes byte shuffle)".into());
    }
    let codec = flags >> 5;
    if codec != CODEC_LZ4 {
        let name = ["blosclz", "lz4", "snappy", "zlib", "zstd"]
            .get(codec as usize)
            .copied()
            .unwrap_or("unknown");
        return Err(format!("Blosc codec {name} is not supported (OpenVDB writes lz4)"));
    }
    if blocksize == 0 || typesize == 0 {
        return Err("a Blosc frame with a zero block or type size".into());
    }
    let nblocks = nbytes.div_ceil(blocksize);
    let starts_end = HEADER + 4 * nblocks;
    if starts_end > src.len() {
        return Err("Blosc block offsets run past the frame".into());
    }
    let shuffle = flags & FLAG_SHUFFLE != 0 && typesize > 1;
    let dont_split = flags & FLAG_DONT_SPLIT != 0;
    let mut tmp = vec![0u8; if shuffle { blocksize.min(nbytes) } else { 0 }];
    for j in 0..nblocks {
        let start = u32_at(HEADER + 4 * j);
        let block_out = &mut out[j * blocksize..((j + 1) * blocksize).min(nbytes)];
        let bsize = block_out.len();
        let leftover = bsize < blocksize;
        let nsplits = if !dont_split && typesize <= MAX_SPLITS && blocksize / typesize >= MIN_BUFFERSIZE && !leftover {
            typesize
        } else {
            1
        };
        let neblock = bsize / nsplits;
        let dest: &mut [u8] = if shuffle { &mut tmp[..bsize] } else { &mut *block_out };
        let mut offset = start;
        for s in 0..nsplits {
            let size_end = offset
                .checked_add(4)
                .filter(|&e| e <= src.len())
                .ok_or("a Blosc block runs past the frame")?;
            let csize = i32::from_le_bytes([src[offset], src[offset + 1], src[offset + 2], src[offset + 3]]);
            let csize = usize::try_from(csize).map_err(|_| "a Blosc block with a negative size")?;
            let data = src
                .get(size_end..size_end + csize)
                .ok_or("a Blosc block runs past the frame")?;
            let part = &mut dest[s * neblock..(s + 1) * neblock];
            if csize == neblock {
                part.copy_from_slice(data);
            } else {
                let n = lz4_flex::block::decompress_into(data, part)
                    .map_err(|e| format!("corrupt LZ4 data in a Blosc block: {e}"))?;
                if n != neblock {
                    return Err(format!("a Blosc block decodes to {n} bytes, not {neblock}"));
                }
            }
            offset = size_end + csize;
        }
        if shuffle {
            unshuffle(typesize, &tmp[..bsize], block_out);
        }
    }
    Ok(())
}

/// Byte shuffle: byte `j` of every `typesize`-byte element, element by element, then
/// byte `j + 1`…; the bytes past the last whole element stay at the end.
fn shuffle(typesize: usize, src: &[u8], dst: &mut [u8]) {
    let n = src.len() / typesize;
    for i in 0..n {
        for j in 0..typesize {
            dst[j * n + i] = src[i * typesize + j];
        }
    }
    dst[n * typesize..].copy_from_slice(&src[n * typesize..]);
}

fn unshuffle(typesize: usize, src: &[u8], dst: &mut [u8]) {
    let n = src.len() / typesize;
    for i in 0..n {
        for j in 0..typesize {
            dst[i * typesize + j] = src[j * n + i];
        }
    }
    dst[n * typesize..].copy_from_slice(&src[n * typesize..]);
}

/// A Blosc frame of `data`: one block, byte-shuffled with `typesize` 4 (OpenVDB's
/// choice for float and Vec3f values), LZ4, not split. `None` when it would not be
/// smaller than `data` (OpenVDB then stores the bytes uncompressed).
pub(crate) fn compress(data: &[u8]) -> Option<Vec<u8>> {
    const TYPESIZE: usize = 4;
    if data.is_empty() || data.len() > i32::MAX as usize / 2 {
        return None;
    }
    let mut shuffled = vec![0u8; data.len()];
    shuffle(TYPESIZE, data, &mut shuffled);
    let packed = lz4_flex::block::compress(&shuffled);
    let total = HEADER + 4 + 4 + packed.len();
    if total >= data.len() {
        return None;
    }
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&[2, 1, FLAG_SHUFFLE | FLAG_DONT_SPLIT | (CODEC_LZ4 << 5), TYPESIZE as u8]);
    for v in [data.len(), data.len(), total] {
        out.extend_from_slice(&(v as u32).to_le_bytes());
    }
    out.extend_from_slice(&((HEADER + 4) as u32).to_le_bytes());
    out.extend_from_slice(&(packed.len() as i32).to_le_bytes());
    out.extend_from_slice(&packed);
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_round_trip_and_hostile_frames_are_errors() {
        let data: Vec<u8> = (0..2048u32).flat_map(|i| ((i / 7) as f32).to_le_bytes()).collect();
        let frame = compress(&data).expect("compressible");
        assert!(frame.len() < data.len() / 2, "{}", frame.len());
        let mut out = vec![0u8; data.len()];
        decompress(&frame, &mut out).unwrap();
        assert_eq!(out, data);
        // Every truncation and every single-byte corruption is an error or a wrong
        // result, never a panic.
        for cut in 0..frame.len() {
            let _ = decompress(&frame[..cut], &mut out);
        }
        for i in 0..frame.len().min(64) {
            let mut bad = frame.clone();
            bad[i] ^= 0xA5;
            let _ = decompress(&bad, &mut out);
        }
        assert!(decompress(&frame, &mut [0u8; 10]).is_err());
    }

    #[test]
    fn split_frames_as_c_blosc_writes_them_decode() {
        // c-blosc's default for LZ4 with typesize 4: four shuffled streams per block.
        let data: Vec<u8> = (0..512u32).flat_map(|i| (i as f32 * 0.25).to_le_bytes()).collect();
        let mut shuffled = vec![0u8; data.len()];
        shuffle(4, &data, &mut shuffled);
        let mut frame = vec![2, 1, FLAG_SHUFFLE | (CODEC_LZ4 << 5), 4];
        let mut body = Vec::new();
        for part in shuffled.chunks(data.len() / 4) {
            let c = lz4_flex::block::compress(part);
            body.extend_from_slice(&(c.len() as i32).to_le_bytes());
            body.extend_from_slice(&c);
        }
        let total = HEADER + 4 + body.len();
        for v in [data.len(), data.len(), total] {
            frame.extend_from_slice(&(v as u32).to_le_bytes());
        }
        frame.extend_from_slice(&((HEADER + 4) as u32).to_le_bytes());
        frame.extend_from_slice(&body);
        let mut out = vec![0u8; data.len()];
        decompress(&frame, &mut out).unwrap();
        assert_eq!(out, data);
    }
}
