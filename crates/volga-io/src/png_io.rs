//! PNG images: 8-bit RGBA out, any common PNG back in as RGBA8.

use std::fs::File;
use std::io::{self, BufReader, Write};
use std::path::Path;

use crate::{write_atomic, IoError};

/// Largest decoded image [`decode_png`] accepts (bytes), so a corrupt header cannot
/// ask for an absurd allocation.
const DECODE_LIMIT_BYTES: usize = 1 << 30;

/// Encodes an 8-bit RGBA, non-interlaced PNG of `width × height` pixels, rows top to
/// bottom, 4 bytes per pixel.
///
/// Fails with [`io::ErrorKind::InvalidInput`] if `rgba8.len() != width·height·4` or a
/// dimension is 0.
pub fn encode_png(w: &mut dyn Write, width: u32, height: u32, rgba8: &[u8]) -> io::Result<()> {
    let expected = u128::from(width) * u128::from(height) * 4;
    if width == 0 || height == 0 {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("PNG of {width}×{height} pixels: both dimensions must be ≥ 1"),
        ));
    }
    if rgba8.len() as u128 != expected {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "PNG of {width}×{height} RGBA8 pixels needs {expected} bytes, got {}",
                rgba8.len()
            ),
        ));
    }
    let mut encoder = png::Encoder::new(w, width, height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(encoding_error)?;
    writer.write_image_data(rgba8).map_err(encoding_error)?;
    writer.finish().map_err(encoding_error)
}

/// Encodes a 16-bit RGBA, non-interlaced PNG of `width × height` pixels, rows top to
/// bottom, 4 channels per pixel (written big-endian, as PNG stores them).
///
/// Fails with [`io::ErrorKind::InvalidInput`] if `rgba16.len() != width·height·4` or a
/// dimension is 0.
pub fn encode_png16(w: &mut dyn Write, width: u32, height: u32, rgba16: &[u16]) -> io::Result<()> {
    let expected = u128::from(width) * u128::from(height) * 4;
    if width == 0 || height == 0 {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("PNG of {width}×{height} pixels: both dimensions must be ≥ 1"),
        ));
    }
    if rgba16.len() as u128 != expected {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "PNG of {width}×{height} RGBA16 pixels needs {expected} channels, got {}",
                rgba16.len()
            ),
        ));
    }
    let bytes: Vec<u8> = rgba16.iter().flat_map(|c| c.to_be_bytes()).collect();
    let mut encoder = png::Encoder::new(w, width, height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Sixteen);
    let mut writer = encoder.write_header().map_err(encoding_error)?;
    writer.write_image_data(&bytes).map_err(encoding_error)?;
    writer.finish().map_err(encoding_error)
}

fn encoding_error(e: png::EncodingError) -> io::Error {
    match e {
        png::EncodingError::IoError(e) => e,
        e => io::Error::new(io::ErrorKind::InvalidInput, e.to_string()),
    }
}

/// Writes an RGBA8 PNG to `path` atomically (see [`write_atomic`]).
pub fn write_png(path: &Path, width: u32, height: u32, rgba8: &[u8]) -> Result<(), IoError> {
    write_atomic(path, |w| encode_png(w, width, height, rgba8))
}

/// Reads a PNG as `(width, height, rgba8)`. Grey, grey+alpha, RGB, palette and 16-bit
/// images are converted to 8-bit RGBA (16-bit channels keep their high byte).
pub fn decode_png(path: &Path) -> Result<(u32, u32, Vec<u8>), IoError> {
    let file = File::open(path).map_err(|e| IoError::io(path, e))?;
    let decoding = |e: png::DecodingError| match e {
        png::DecodingError::IoError(e) if e.kind() != io::ErrorKind::UnexpectedEof => IoError::io(path, e),
        e => IoError::format(path, None, format!("invalid PNG: {e}")),
    };
    let mut decoder = png::Decoder::new_with_limits(
        BufReader::new(file),
        png::Limits {
            bytes: DECODE_LIMIT_BYTES,
        },
    );
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().map_err(decoding)?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).map_err(decoding)?;
    buf.truncate(info.buffer_size());
    if info.bit_depth != png::BitDepth::Eight {
        return Err(IoError::format(
            path,
            None,
            format!("unsupported PNG bit depth {:?}", info.bit_depth),
        ));
    }
    let pixels = info.width as usize * info.height as usize;
    let rows_packed = info.line_size == info.width as usize * info.color_type.samples();
    if !rows_packed || buf.len() != pixels * info.color_type.samples() {
        return Err(IoError::format(path, None, "unexpected PNG row layout"));
    }
    let rgba = match info.color_type {
        png::ColorType::Rgba => buf,
        png::ColorType::Rgb => buf.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect(),
        png::ColorType::GrayscaleAlpha => buf.chunks_exact(2).flat_map(|p| [p[0], p[0], p[0], p[1]]).collect(),
        png::ColorType::Grayscale => buf.iter().flat_map(|&g| [g, g, g, 255]).collect(),
        png::ColorType::Indexed => return Err(IoError::format(path, None, "palette PNG was not expanded")),
    };
    Ok((info.width, info.height, rgba))
}

#[cfg(test)]
mod tests {

    /// A 16-bit PNG reads back (through the 8-bit decoder) as the high bytes.
    #[test]
    fn sixteen_bit_png_round_trips_its_high_bytes() {
        let rgba16: Vec<u16> = (0..2 * 3 * 4).map(|i| (i as u16) * 2741 + 13).collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        let mut bytes = Vec::new();
        encode_png16(&mut bytes, 2, 3, &rgba16).unwrap();
        std::fs::write(&path, &bytes).unwrap();
        let (w, h, rgba8) = decode_png(&path).unwrap();
        assert_eq!((w, h), (2, 3));
        let high: Vec<u8> = rgba16.iter().map(|c| (c >> 8) as u8).collect();
        assert_eq!(rgba8, high);
        assert!(encode_png16(&mut Vec::new(), 2, 2, &rgba16).is_err());
    }

    use super::*;

    fn pattern(w: u32, h: u32) -> Vec<u8> {
        (0..w * h * 4).map(|i| (i * 37 % 251) as u8).collect()
    }

    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("img.png");
        let rgba = pattern(7, 5);
        write_png(&path, 7, 5, &rgba).unwrap();
        assert_eq!(decode_png(&path).unwrap(), (7, 5, rgba.clone()));

        let mut bytes = Vec::new();
        encode_png(&mut bytes, 7, 5, &rgba).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(std::fs::read(&path).unwrap(), bytes);
    }

    #[test]
    fn wrong_length_is_an_error() {
        let mut out = Vec::new();
        let e = encode_png(&mut out, 4, 4, &[0; 63]).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        assert!(e.to_string().contains("64"), "{e}");
        assert!(encode_png(&mut out, 0, 4, &[]).is_err());
        assert!(encode_png(&mut out, u32::MAX, u32::MAX, &[0; 4]).is_err());

        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.png");
        assert!(write_png(&path, 2, 2, &[0; 3]).is_err());
        assert!(!path.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn converts_rgb_and_grey() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("grey.png");
        let mut f = File::create(&path).unwrap();
        let mut enc = png::Encoder::new(&mut f, 2, 1);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header().unwrap().write_image_data(&[10, 200]).unwrap();
        drop(f);
        assert_eq!(
            decode_png(&path).unwrap(),
            (2, 1, vec![10, 10, 10, 255, 200, 200, 200, 255])
        );

        let path = dir.path().join("rgb.png");
        let mut f = File::create(&path).unwrap();
        let mut enc = png::Encoder::new(&mut f, 1, 1);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header().unwrap().write_image_data(&[1, 2, 3]).unwrap();
        drop(f);
        assert_eq!(decode_png(&path).unwrap(), (1, 1, vec![1, 2, 3, 255]));
    }

    #[test]
    fn decode_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("junk.png");
        std::fs::write(&path, b"not a png at all").unwrap();
        let e = decode_png(&path).unwrap_err();
        assert!(matches!(e, IoError::Format { .. }), "{e:?}");
        assert!(e.to_string().contains("junk.png"), "{e}");

        let mut bytes = Vec::new();
        encode_png(&mut bytes, 3, 3, &pattern(3, 3)).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 20]).unwrap();
        assert!(decode_png(&path).is_err());

        let e = decode_png(&dir.path().join("missing.png")).unwrap_err();
        assert!(matches!(e, IoError::Io { .. }), "{e:?}");
    }
}
